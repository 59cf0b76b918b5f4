#pragma once
/// Irregular bodies (docs/geometry.md): point packings bonded within a radius (sampling.hpp), and
/// closed triangle meshes (mesh_reader.hpp) voxelised into a simple-cubic lattice (voxelise.hpp).
#include "qbond/builders/mesh_reader.hpp"
#include "qbond/builders/sampling.hpp"
#include "qbond/builders/voxelise.hpp"
