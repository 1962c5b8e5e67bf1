"""Engine materials -> Blender Principled BSDF nodes (the optimiser's recovered mesh materials).

    write_principled(material, params)    # params: an engine material (material_export's fields)

Sets the inputs of the material's Principled BSDF (made and linked to the output when it has none)
so that this Blender's Cycles renders what the engine rendered, in this Blender's model
(compat.principled_model()):
  both:  Base Color, Roughness, Metallic, and the distribution (GGX for "principled",
         Multiscatter GGX for "principled-multiscatter")
  v2 (4.0+): IOR, Specular IOR Level, Specular Tint (a colour), Diffuse Roughness (4.3+)
  v1 (3.x):  Specular, Specular Tint (a float)
A field the params lack keeps the node's value. Sockets are looked up by name and a missing one
(another Blender's name) is an error naming the material and the socket, never skipped.
"""

from ..errors import OptimizeError
from . import compat

# engine field -> socket name, per model
_V1 = (("base_color", "Base Color"), ("roughness", "Roughness"), ("metallic", "Metallic"),
       ("specular", "Specular"), ("specular_tint", "Specular Tint"))
_V2 = (("base_color", "Base Color"), ("roughness", "Roughness"), ("metallic", "Metallic"), ("ior", "IOR"),
       ("specular_ior_level", "Specular IOR Level"), ("specular_tint_color", "Specular Tint"),
       ("diffuse_roughness", "Diffuse Roughness"))
_OPTIONAL = {"Diffuse Roughness"}  # (4.0-4.2 have none: the engine's value is 0, Lambert, as theirs)
_DISTRIBUTIONS = {"principled": "GGX", "principled-multiscatter": "MULTI_GGX"}


def principled_node(material):
    """The material's Principled BSDF (the one feeding the output, else the first), made and linked to the
    Material Output when it has none."""
    tree = compat.ensure_nodes(material)
    nodes = tree.nodes
    from .material_export import output_surface_node
    node = output_surface_node(tree)
    if node is None or node.type != "BSDF_PRINCIPLED":
        node = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if node is None:
        out = next((n for n in nodes if n.type == "OUTPUT_MATERIAL"), None) or nodes.new("ShaderNodeOutputMaterial")
        node = nodes.new("ShaderNodeBsdfPrincipled")
        node.location = (out.location.x - 300, out.location.y)
        tree.links.new(node.outputs[0], out.inputs["Surface"])
    return node


def write_principled(material, params, model=None):
    """Sets the Principled BSDF of `material` from the engine material `params`; returns the node."""
    model = model or compat.principled_model()
    node = principled_node(material)
    for field, socket in (_V2 if model == "principled-v2" else _V1):
        if field not in params:
            continue
        sock = node.inputs.get(socket)
        if sock is None:
            if socket in _OPTIONAL and abs(float(params[field])) < 1e-6:
                continue
            raise OptimizeError("material '%s': its Principled BSDF has no '%s' input (Blender %s, model %s)"
                                % (material.name, socket, ".".join(map(str, compat.VERSION)), model))
        value = params[field]
        if isinstance(value, (list, tuple)):
            sock.default_value = (*[float(v) for v in value[:3]], 1.0)
        else:
            sock.default_value = float(value)
    distribution = _DISTRIBUTIONS.get(params.get("shader"))
    if distribution is not None:
        node.distribution = distribution
    return node
