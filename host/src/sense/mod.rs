//! The sensing wing: where the finger is. Depth frames to the paper's
//! contact-area centroid ([`track`]), centroid sources, filters and the
//! streaming loop to a device ([`stream`]), and the one reader thread.
//!
//! Imports the base, planning and the device wing's `Backend`; never the lab.

pub mod reader;
pub mod stream;
pub mod track;
