//! Scene file (placeholder).
