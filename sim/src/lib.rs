//! Host-side simulator of the sensor bus (placeholder, see issue 4).
