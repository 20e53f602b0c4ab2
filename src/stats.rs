//! Environment statistics of a set of scenes.
