//! Register drivers (target only). Filled below.
