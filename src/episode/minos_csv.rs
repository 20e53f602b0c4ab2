//! (to write)
