//! gmsh meshing (placeholder).
