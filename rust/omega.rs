//! omega cut (being written).
