"""Meshes to grids and back: voxelizing, marching cubes in the input's own coordinates, the unit
frame, the fine pass, moving the input's vertices, the output choice, point clouds made solid, and
the mesh pipeline that composes them with :mod:`skelfilter.core`."""
