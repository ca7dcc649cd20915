//! The 8-node hexahedron (placeholder).
