"""The MeshLab side: filter descriptions in MeshLab's terms, .mlx filter scripts, MeshLab's own
filters run through pymeshlab in a child process, and the filters on a PyMeshLab MeshSet."""
