//! Firmware placeholder: the RTIC application lands with the firmware issue.
#![no_std]
