//! I2C1 master model (RM0008 §26, errata ES096). Placeholder: the agreed
//! interface only; the model is being written.
