//! Exhaustive SSD (being written).
