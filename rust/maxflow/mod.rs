//! Max-flow (being written).
