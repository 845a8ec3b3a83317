//! Placeholder; see issue 7.
#![no_std]
#![no_main]
