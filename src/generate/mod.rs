//! Procedural houses written in real dataset formats.
