// A unit cube meshed with tetrahedra by Gmsh (tests/file_formats_test.cpp reads its output):
//   gmsh -3 cube.geo -format msh22 -o cube_gmsh22.msh
//   gmsh -3 cube.geo -format msh41 -o cube_gmsh41.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Physical Volume("solid") = {1};
Physical Surface("bottom") = {5};
Mesh.MeshSizeMax = 0.5;
