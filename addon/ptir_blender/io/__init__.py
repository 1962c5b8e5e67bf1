"""Pure-Python file and format helpers of the add-on (no bpy): unit-testable with plain pytest.

Modules:
    splat_ply        splat PLY reading (every variant the engine reads) and writing, activations
    supersplat_ply   the SuperSplat / PlayCanvas compressed-PLY decoder
    splat_transform  the one transform rule: object transforms folded into splats
    mesh_ply         binary triangle-mesh PLY writing/reading (numpy)
    surface_splats   polygons -> flat surface Gaussians, 3DGS PLY writing with PTIR material properties
    scene_file       the scene-file schema helpers (docs/scene_format.md): matrices, camera field of view, JSON
    dataset_file     transforms files for the optimiser, mesh_materials.json
    engine_client    the one client of the engine: `ptir serve` requests, the command lines of one-off
                     jobs (render, fit, optimize), running a job to its end
    cli              the ptir child process: start, progress parsing, cancel
    engine_process   the persistent `ptir serve` process: JSON lines in and out, cancel, death
    raw_pixels       the engine's raw AOV images as render passes; hdr_file: Radiance .hdr writing
    native_module    the optional native module `ptir`, loaded lazily
    atomic_file      temp-and-rename writes; sh_basis: the SH DC constant
Nothing here imports bpy (tests/check_layers.py --addon checks it). Errors are the classes of
../errors.py (all PtirError).
"""
