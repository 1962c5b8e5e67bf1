"""Pure-Python file and format helpers of the add-on (no bpy): unit-testable with plain pytest.

Modules:
    mesh_ply        binary triangle-mesh PLY writing/reading (numpy)
    surface_splats  polygons -> flat surface Gaussians, 3DGS PLY writing with PTIR material properties
    scene_file      the scene-file schema helpers (docs/scene_format.md): matrices, camera field of view, JSON
"""
