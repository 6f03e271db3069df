//! synthesis copy (being written).
