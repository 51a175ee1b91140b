"""Scene files: a YAML description of envs, meshes, textures, materials and entities, loaded
into a cressim.World. Every entity is made once per env (`envs: N`). Errors name the file, the
line and the field, also those prepare() finds later (a negative mass, a restitution of 5): the
world remembers where each entity and field was written (World.set_source). The format (every
key optional unless said)::

    envs: 2
    layout: {max_renderables_per_env: 16, max_lights_per_env: 4, max_cameras_per_env: 4}
    environment: {sky: [0.3, 0.35, 0.4], ground: [0.15, 0.12, 0.1], intensity: 1}   # or map: <texture>
                                         # (equirectangular, image-based lighting; docs/render.md)
    meshes:                              # named meshes (files relative to the scene file)
      bunny: {file: meshes/bunny.obj, scale: 1.0}
      ball: {sphere: {radius: 0.1}}      # or box: {half_extents}, capsule: {radius, half_height},
                                         # plane: {half_size}
    textures:
      checker: {checker: {size: 64, squares: 8}}   # or {file: wood.png}
    materials:
      red: {color: [1, 0, 0, 1], metallic: 0, roughness: 0.5, texture: checker}
      bumpy: {texture: checker, normal_map: bumps, normal_scale: 1}   # bumps: a texture of normals
    entities:
      - name: ground
        transform: {position: [0, 0, 0], rotation: [0, 0, 0, 1], scale: [1, 1, 1]}
        renderable: {mesh: ball, material: red, segmentation_id: 3}   # or mesh: {box: {...}},
                                         # and the material keys inline
        collider: {shapes: [{box: {half_extents: [1, 1, 0.1]}}], static_friction: 0.5}
        rigid_body: {mass: 1.0}
      - name: camera
        transform: {position: [1, -1, 1], look_at: [0, 0, 0]}   # look_at: +z towards the point
        camera: {width: 128, height: 96, fov_y: 50}   # products: [rgb, depth, segmentation] (default)
      - name: sun
        transform: {position: [0, 0, 2], look_at: [0.2, 0.3, 0]}
        light: {kind: directional, intensity: 2.5, shadows: true, shadow_extent: 1.5}
      - name: tissue                     # particles (entity frame), drawn from the physics buffers
        transform: {position: [0, 0, 0.1]}
        soft_body: {box: {half_extents: [0.08, 0.08, 0.08], cells: [3, 3, 3]}, radius: 0.02,
                    youngs_modulus: 10e3, poisson_ratio: 0.45, density: 1000, damping: 0, friction: 0.5,
                    fixed: {below: {axis: z, value: -0.08}}}
                                         # or cylinder: {radius, half_height, cells_across, cells_along},
                                         # or mesh: meshes/liver.vtk (tets of a legacy VTK .vtk or a Gmsh .msh
                                         # file; cressim/tet_mesh_file.py) and scale: 0.001 (file unit in m);
                                         # expert model: mass (per particle), distance_compliance, volume_compliance
                                         # thermal: {} (liver) or {conductivity, specific_heat, temperature,
                                         # frequency_factor, activation_energy, damage_onset, coagulated_stiffening,
                                         # coagulated_shrinkage}: heat (docs/particles.md)
                                         # fixed (clamped; strands too): [0, 5, ...], or the particles in a
                                         # region of the entity frame: {box: {center, half_extents}},
                                         # {below: {axis: x|y|z, value}} or {above: {axis, value}}
        material: {color: [0.8, 0.35, 0.3], roughness: 0.4, segmentation_id: 5}   # or a name
        ultrasound_tissue: {density: 2e9, attenuation: 0.5, seed: 1,   # scatterers per m^3, dB/cm/MHz
                            inclusions: [{center: [0, 0, 0], radius: 0.01, amplitude_scale: 0}]}
                                         # on a soft_body the scatterers fill its tets; otherwise region:
                                         # box|sphere|cylinder, size: half extents|[radius]|[radius, half_height],
                                         # center; count instead of density; amplitude_mean, amplitude_std
      - name: probe                      # an ultrasound probe looks along its +z, scanlines along x
        transform: {position: [0, 0, 0.19], rpy_deg: [180, 0, 0]}
        ultrasound_probe: {kind: linear, scanlines: 64, line_spacing: 0.0003, line_length: 0.04,
                           center_frequency: 7.5e6, width: 96, height: 96}   # any UltrasoundProbe field
      - name: blood
        fluid: {block: {counts: [10, 6, 2], spacing: 0.03, origin: [-0.1, -0.2, 0.015]}, radius: 0.015,
                rest_density: 1060, viscosity: 0.05, budget: 300,
                emit_rate: 4, emit_width: 2, emit_origin: [0, 0, 0.3], emit_velocity: [0, 0, -0.5]}
                                         # an emitter (a bleeding source) starts up to emit_rate particles a
                                         # frame on an emit_width-square nozzle at emit_origin (entity frame)
                                         # in the budget's free slots; with an emitter the block is optional
      - name: thread
        strand: {line: {start: [0, 0, 0.5], end: [0.3, 0, 0.5], count: 20}, radius: 0.004, fixed: [0]}
    randomization:                       # domain randomization (docs/envs.md, "Domain randomization")
      - {param: mass, entity: ball, distribution: uniform, range: [0.5, 2], operation: scale, when: reset}
      - {param: color, entity: ground, range: [0.2, 0.9], operation: abs, when: interval, every: 100}
      - {param: texture, entity: ground, distribution: choice, choices: [checker, -1], operation: abs}

Surgical scenes built from these (docs/scenes.md): scenes/tissue_retraction.yaml,
scenes/blood_suction.yaml, scenes/ultrasound_phantom.yaml.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

import cressim
from cressim import io
from cressim.config import Field, SceneFileError, read_fields
from cressim.randomization.config import parse_terms
from cressim.tet_mesh_file import load_tet_mesh

# the scene format's top-level sections: the world's, read here, and the twin's, read by
# cressim.twin_scene_file (one file may hold both: a task's world and its twin)
ENGINE_SECTIONS = ("envs", "layout", "environment", "meshes", "textures", "materials", "entities", "randomization")
TWIN_SECTIONS = ("arm", "cart", "num_envs", "rates", "camera", "sensors", "record", "world")
MATERIAL_KEYS = ("color", "metallic", "roughness", "texture", "normal_map", "normal_scale")
# an entity's keys and the components they make
COMPONENTS = {"transform": "Transform", "renderable": "Renderable", "camera": "Camera", "light": "Light",
              "rigid_body": "RigidBody", "collider": "Collider", "soft_body": "SoftBody", "fluid": "Fluid",
              "strand": "Strand", "tendons": "Tendons", "material": "Material",
              "ultrasound_probe": "UltrasoundProbe", "ultrasound_tissue": "UltrasoundTissue"}
# keys that author component fields of another name (the rest author the field of their name)
AUTHORS = {("Transform", "look_at"): ("rotation",), ("Transform", "rpy_deg"): ("rotation",),
           ("SoftBody", "box"): ("positions", "tets", "triangles"),
           ("SoftBody", "cylinder"): ("positions", "tets", "triangles"),
           ("SoftBody", "mesh"): ("positions", "tets", "triangles"), ("SoftBody", "scale"): ("positions",),
           ("Fluid", "block"): ("positions",), ("Strand", "line"): ("points",),
           ("Renderable", "material"): ()}
SHAPE_SIZE_KEYS = ("radius", "half_extents", "half_height")
EMITTER_KEYS = ("emit_rate", "emit_width", "emit_origin", "emit_velocity")
PROBE_INTS = ("scanlines", "width", "height", "radial_decimation")
PROBE_NUMBERS = ("line_length", "line_spacing", "sector_angle", "radius", "sampling_frequency", "center_frequency",
                 "fractional_bandwidth", "lateral_beam_width", "elevational_beam_width", "speed_of_sound",
                 "metres_per_unit", "dynamic_range", "gain", "time_gain_compensation", "focal_depth",
                 "coupling_impedance", "specular_amplitude")
# an ultrasound tissue region's sizes: box half extents, sphere radius, cylinder radius and half height
REGION_SIZES = {"box": 3, "sphere": 1, "cylinder": 2}


def _quat_look_at(eye, target, up=(0.0, 0.0, 1.0)) -> tuple[float, ...]:
    """The rotation whose +z points from eye to target, with +y down (x = z cross up)."""
    z = np.subtract(target, eye).astype(float)
    if np.linalg.norm(z) < 1e-12:
        raise ValueError("look_at: the point is the position itself")
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:  # looking straight up or down: any right vector
        x = np.cross(z, (0.0, 1.0, 0.0))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.column_stack([x, y, z])
    # rotation matrix -> quaternion (x, y, z, w)
    t = np.trace(m)
    if t > 0:
        s = 2 * math.sqrt(t + 1)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4)
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * math.sqrt(1 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i] = s / 4
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
    return tuple(float(v) for v in q)


class _Loader:
    def __init__(self, root: Field, base: Path, *, segmentation_offset: int = 0, skip: tuple = ()):
        self.root, self.base = root, base
        self.segmentation_offset, self.skip = segmentation_offset, skip
        self.labels: dict[int, str] = {}  # segmentation id -> the entity that drew it
        self.probes: list[tuple] = []  # (position, xyzw) of each ultrasound probe entity, env 0's
        self.meshes: dict[str, int] = {}
        self.textures: dict[str, int] = {}
        self.materials: dict[str, dict] = {}
        self.material_fields: dict[str, dict[str, Field]] = {}
        self.inline_meshes: dict[tuple, int] = {}
        self.randomization: list = []  # the file's domain randomization terms (cressim.randomization.Term)

    def load(self, world: cressim.World | None = None) -> cressim.World:
        """A new world, or the file's entities added to every env of `world` (its envs and
        layout then stand; the file's are checked but not used)."""
        top = self.root.keys(ENGINE_SECTIONS + TWIN_SECTIONS)  # the twin's, if any, are read by the twin
        envs = top["envs"].int(1) if "envs" in top else 1
        layout = {}
        if "layout" in top:
            for k, f in top["layout"].keys(("max_renderables_per_env", "max_lights_per_env",
                                            "max_cameras_per_env")).items():
                layout[k] = f.int(1)
        if world is not None:
            envs = world.layout.num_envs
        self.world = world if world is not None else cressim.World(cressim.SceneLayout(envs, **layout))
        for name, f in (top["textures"].items() if "textures" in top else {}).items():
            self.textures[name] = self.world.add_texture(self.texture(f))
        if "randomization" in top:  # checked here; used by the env that runs the scene (file_randomization)
            self.randomization = parse_terms(top["randomization"], self.textures)
        for name, f in (top["meshes"].items() if "meshes" in top else {}).items():
            self.meshes[name] = self.world.add_mesh(self.mesh(f))
        for name, f in (top["materials"].items() if "materials" in top else {}).items():
            self.material_fields[name] = f.keys(MATERIAL_KEYS)
            self.materials[name] = self.material(self.material_fields[name])
        entities = top["entities"].list() if "entities" in top else []
        environment = self.environment(top["environment"]) if "environment" in top else None
        for env in range(envs):
            if environment is not None:
                ent = self.world.create_entity(env=env, name="environment")
                ent.add(environment)
                self.world.set_source(ent.id, "", top["environment"].where)
                for k, v in top["environment"].items().items():
                    self.world.set_source(ent.id, f"EnvironmentLight.{k}", v.where)
            for f in entities:
                self.entity(env, f)
        return self.world

    # --- resources -------------------------------------------------------------------------
    def _file(self, f: Field) -> Path:
        p = Path(f.str())
        p = p if p.is_absolute() else self.base / p
        if not p.exists():
            raise f.fail(f"no such file: {p}")
        return p

    def texture(self, f: Field) -> cressim.Texture:
        kinds = f.keys(("file", "checker"))
        if len(kinds) != 1:
            raise f.fail("give one of: file, checker")
        (kind, g), = kinds.items()
        if kind == "file":
            try:
                return io.load_texture(self._file(g))
            except (OSError, ValueError) as e:
                raise g.fail(f"cannot read the image: {e}") from None
        opts = g.keys(("size", "squares", "colors")) if g.is_map() else {}
        colors = ((230, 230, 230), (40, 40, 40))
        if "colors" in opts:
            colors = tuple(tuple(int(round(255 * c)) for c in x.vec(3)) for x in opts["colors"].list())
        return io.checker_texture(opts["size"].int(2) if "size" in opts else 64,
                                  opts["squares"].int(1) if "squares" in opts else 8, colors)

    def mesh(self, f: Field) -> cressim.Mesh:
        kinds = f.keys(("file", "scale", "sphere", "box", "capsule", "plane"))
        shape = [k for k in kinds if k != "scale"]
        if len(shape) != 1:
            raise f.fail("give one of: file, sphere, box, capsule, plane")
        kind, g = shape[0], kinds[shape[0]]
        if kind == "file":
            path = self._file(g)
            try:
                return io.load_mesh(path, scale=kinds["scale"].float() if "scale" in kinds else 1.0)
            except Exception as e:  # trimesh raises many kinds
                raise g.fail(f"cannot load the mesh: {e}") from None
        if "scale" in kinds:
            raise kinds["scale"].fail("scale applies to mesh files; size primitives directly")
        opts = g.items() if g.is_map() else {}
        need = {"sphere": ("radius",), "box": ("half_extents",), "capsule": ("radius", "half_height"),
                "plane": ("half_size",)}[kind]
        g.keys(need)
        for k in need:
            if k not in opts:
                raise g.fail(f"{kind} needs '{k}'")
        if kind == "sphere":
            return cressim.Mesh.sphere(opts["radius"].float())
        if kind == "box":
            return cressim.Mesh.box(opts["half_extents"].vec(3))
        if kind == "capsule":
            return cressim.Mesh.capsule(opts["radius"].float(), opts["half_height"].float())
        return cressim.Mesh.plane(opts["half_size"].float())

    def material(self, m: dict[str, Field]) -> dict:
        out = {}
        if "color" in m:
            c = m["color"].vec((3, 4))
            out["color"] = (*c, 1.0) if len(c) == 3 else c
        for k in ("metallic", "roughness", "normal_scale"):
            if k in m:
                out[k] = m[k].float()
        for k in ("texture", "normal_map"):
            if k in m:
                name = m[k].str()
                if name not in self.textures:
                    raise m[k].fail(f"no texture '{name}'; textures: {', '.join(self.textures) or 'none'}")
                out[k] = self.textures[name]
        return out

    def environment(self, f: Field) -> cressim.EnvironmentLight:
        e = f.keys(("sky", "ground", "intensity", "map"))
        out = {k: (v.float() if k == "intensity" else v.vec(3)) for k, v in e.items() if k != "map"}
        if "map" in e:
            name = e["map"].str()
            if name not in self.textures:
                raise e["map"].fail(f"no texture '{name}'; textures: {', '.join(self.textures) or 'none'}")
            out["map"] = self.textures[name]
        return cressim.EnvironmentLight(**out)

    # --- entities --------------------------------------------------------------------------
    def entity(self, env: int, f: Field) -> None:
        e = f.keys(("name", "transform", "renderable", "camera", "light", "rigid_body", "collider", "soft_body",
                    "fluid", "strand", "tendons", "material", "ultrasound_probe", "ultrasound_tissue"))
        if any(k in e for k in self.skip):
            return
        name = e["name"].str() if "name" in e else ""
        self.entity_name = name
        ent = self.world.create_entity(env=env, name=name)
        transform = self.transform(e["transform"]) if "transform" in e else cressim.Transform()
        ent.add(transform)
        if env == 0 and "ultrasound_probe" in e:
            self.probes.append((tuple(transform.position), tuple(transform.rotation)))
        for key, make in (("renderable", self.renderable), ("camera", self.camera), ("light", self.light),
                          ("rigid_body", self.rigid_body), ("collider", self.collider), ("soft_body", self.soft_body),
                          ("fluid", self.fluid), ("strand", self.strand),
                          ("tendons", lambda g: self.tendons(g, e)), ("material", self.look),
                          ("ultrasound_probe", self.ultrasound_probe), ("ultrasound_tissue", self.ultrasound_tissue)):
            if key in e:
                try:
                    ent.add(make(e[key]))
                except (TypeError, ValueError) as err:
                    if isinstance(err, SceneFileError):
                        raise
                    raise e[key].fail(str(err)) from None
        self.sources(ent.id, f, e)

    def sources(self, entity: int, f: Field, keys: dict[str, Field]) -> None:
        """Remembers where the entity, its components and their fields were written, so that
        errors prepare() finds later start with the file and line."""
        put = self.world.set_source
        put(entity, "", f.where)
        for key, c in keys.items():
            component = COMPONENTS.get(key)
            if component is None:
                continue
            put(entity, component, c.where)
            if not c.is_map():  # a material by name
                for k, v in self.material_fields.get(c.str(), {}).items():
                    put(entity, f"{component}.{k}", v.where)
                continue
            fields = c.items()
            if "material" in fields and component == "Renderable":  # a named material, then inline keys
                for k, v in self.material_fields.get(fields["material"].str(), {}).items():
                    put(entity, f"Renderable.{k}", v.where)
            for k, v in fields.items():
                for name in AUTHORS.get((component, k), (k,)):
                    put(entity, f"{component}.{name}", v.where)
            if component == "Collider" and "shapes" in fields:
                for i, shape in enumerate(fields["shapes"].list()):
                    put(entity, f"Collider.shapes[{i}]", shape.where)
                    for g in shape.items().values():  # its one kind: {radius, position, ...}
                        for k, v in (g.items() if g.is_map() else {}).items():
                            put(entity, f"Collider.shapes[{i}].{'size' if k in SHAPE_SIZE_KEYS else k}", v.where)
            if component == "UltrasoundTissue" and "inclusions" in fields:
                for i, inclusion in enumerate(fields["inclusions"].list()):
                    put(entity, f"UltrasoundTissue.inclusions[{i}]", inclusion.where)
                    for k, v in (inclusion.items() if inclusion.is_map() else {}).items():
                        put(entity, f"UltrasoundTissue.inclusions[{i}].{k}", v.where)

    def transform(self, f: Field) -> cressim.Transform:
        t = f.keys(("position", "rotation", "scale", "look_at", "rpy_deg"))
        position = t["position"].vec(3) if "position" in t else (0.0, 0.0, 0.0)
        given = [k for k in ("rotation", "look_at", "rpy_deg") if k in t]
        if len(given) > 1:
            raise t[given[1]].fail(f"give one of rotation, look_at, rpy_deg (also has {given[0]})")
        rotation = (0.0, 0.0, 0.0, 1.0)
        if "rotation" in t:
            rotation = t["rotation"].vec(4)
            if abs(np.linalg.norm(rotation) - 1) > 1e-3:
                raise t["rotation"].fail(f"a rotation is a unit quaternion (x, y, z, w); |q| = {np.linalg.norm(rotation):.4f}")
        elif "look_at" in t:
            try:
                rotation = _quat_look_at(position, t["look_at"].vec(3))
            except ValueError as e:
                raise t["look_at"].fail(str(e)) from None
        elif "rpy_deg" in t:
            r, p, y = (math.radians(a) / 2 for a in t["rpy_deg"].vec(3))  # z-y-x (yaw, pitch, roll)
            cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
            rotation = (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                        cr * cp * cy + sr * sp * sy)
        scale = t["scale"].vec(3) if "scale" in t else (1.0, 1.0, 1.0)
        return cressim.Transform(position=position, rotation=rotation, scale=scale)

    def renderable(self, f: Field) -> cressim.Renderable:
        r = f.keys(("mesh", "material", *MATERIAL_KEYS, "segmentation_id"))
        if "mesh" not in r:
            raise f.fail("a renderable needs 'mesh' (a name from meshes, or a primitive)")
        m = r["mesh"]
        if isinstance(m.node, yaml.ScalarNode):
            name = m.str()
            if name not in self.meshes:
                raise m.fail(f"no mesh '{name}'; meshes: {', '.join(self.meshes) or 'none'}")
            mesh = self.meshes[name]
        else:  # an inline primitive, shared between envs
            key = yaml.serialize(m.node)
            if key not in self.inline_meshes:
                self.inline_meshes[key] = self.world.add_mesh(self.mesh(m))
            mesh = self.inline_meshes[key]
        opts = {}
        if "material" in r:
            name = r["material"].str()
            if name not in self.materials:
                raise r["material"].fail(f"no material '{name}'; materials: {', '.join(self.materials) or 'none'}")
            opts.update(self.materials[name])
        opts.update(self.material({k: v for k, v in r.items() if k in MATERIAL_KEYS}))
        if "segmentation_id" in r:
            opts["segmentation_id"] = self.label(r["segmentation_id"].int(1))
        return cressim.Renderable(mesh, **opts)

    def label(self, segmentation_id: int) -> int:
        """The id drawn (offset when the scene joins a world that numbers its own first) and its name."""
        drawn = segmentation_id + self.segmentation_offset
        self.labels[drawn] = self.entity_name
        return drawn

    # particle objects: their parameters as keyword arguments, their points from a generator
    @staticmethod
    def _need(f: Field, c: dict[str, Field], keys: tuple[str, ...], what: str) -> dict[str, Field]:
        for k in keys:
            if k not in c:
                raise f.fail(f"{what} needs '{k}'")
        return c

    def _options(self, c: dict[str, Field], ints=()) -> dict:
        return {k: (v.int(0) if k in ints else v.float()) for k, v in c.items()}

    def soft_body(self, f: Field) -> cressim.SoftBody:
        c = f.keys(("box", "cylinder", "mesh", "scale", "radius", "youngs_modulus", "poisson_ratio", "density", "mass",
                    "distance_compliance", "volume_compliance", "damping", "friction", "fixed", "thermal"))
        shapes = [k for k in ("box", "cylinder", "mesh") if k in c]
        if len(shapes) != 1:
            raise f.fail("a soft_body needs one of: box, cylinder, mesh")
        shape, g = shapes[0], c[shapes[0]]
        if "scale" in c and shape != "mesh":
            raise c["scale"].fail("scale applies to mesh files; size box and cylinder directly")
        if shape == "mesh":
            path, scale = self._file(g), c["scale"].positive() if "scale" in c else 1.0
            try:
                mesh = load_tet_mesh(path, scale)
            except (OSError, ValueError) as e:
                raise g.fail(f"cannot read the tet mesh: {e}") from None
        elif shape == "box":
            b = self._need(g, g.keys(("half_extents", "cells")), ("half_extents", "cells"), "box")
            mesh = cressim.TetMesh.box(b["half_extents"].vec(3), b["cells"].ints(3, 1))
        else:
            keys = ("radius", "half_height", "cells_across", "cells_along")
            b = self._need(g, g.keys(keys), keys, "cylinder")
            mesh = cressim.TetMesh.cylinder(b["radius"].float(), b["half_height"].float(), b["cells_across"].int(1),
                                            b["cells_along"].int(1))
        fixed = self.selection(c["fixed"], mesh.positions) if "fixed" in c else None
        opts = self._options({k: v for k, v in c.items() if k not in (shape, "scale", "fixed", "thermal")})
        if "thermal" in c:  # {} for liver's defaults; values checked by the engine (file:line there too)
            keys = ("conductivity", "specific_heat", "temperature", "frequency_factor", "activation_energy",
                    "damage_onset", "coagulated_stiffening", "coagulated_shrinkage")
            opts["thermal"] = cressim.Thermal(**self._options(c["thermal"].keys(keys)))
        try:  # the material-or-compliance choice is checked by the constructor
            return cressim.SoftBody(mesh.positions, mesh.tets, mesh.triangles, fixed=fixed, **opts)
        except ValueError as exc:
            raise f.fail(str(exc)) from None

    def selection(self, f: Field, points: np.ndarray):
        """`fixed`: a list of particle indices, or a region of the entity frame (a box, or below
        or above a plane across an axis) and the particles inside it. Points on the region's
        surface count as inside (1e-5 of the body's size), so a plane through a layer of
        vertices holds the whole layer despite float32 rounding."""
        if not f.is_map():
            return [x.int(0) for x in f.list()]
        kinds = f.keys(("box", "below", "above"))
        if len(kinds) != 1:
            raise f.fail("give one region: box {center, half_extents}, below {axis, value} or above {axis, value}")
        (kind, g), = kinds.items()
        p = np.asarray(points, np.float64)
        lo, hi = p.min(axis=0), p.max(axis=0)
        tolerance = 1e-5 * float(np.max(hi - lo))
        if kind == "box":
            b = self._need(g, g.keys(("center", "half_extents")), ("center", "half_extents"), "box")
            center, half = np.array(b["center"].vec(3, "finite")), np.array(b["half_extents"].vec(3, "positive"))
            inside = (np.abs(p - center) <= half + tolerance).all(axis=1)
        else:
            a = self._need(g, g.keys(("axis", "value")), ("axis", "value"), kind)
            axis = a["axis"].str()
            if axis not in ("x", "y", "z"):
                raise a["axis"].fail(f"expected x, y or z, got '{axis}'")
            value, column = a["value"].finite(), p[:, "xyz".index(axis)]
            inside = column <= value + tolerance if kind == "below" else column >= value - tolerance
        chosen = np.flatnonzero(inside)
        if len(chosen) == 0:
            span = ", ".join(f"{n} [{lo[i]:.4g}, {hi[i]:.4g}]" for i, n in enumerate("xyz"))
            raise f.fail(f"the region holds none of the {len(p)} particles (entity frame: {span})")
        return chosen

    def fluid(self, f: Field) -> cressim.Fluid:
        c = f.keys(("block", "radius", "budget", "rest_density", "viscosity", "cohesion", "surface_tension",
                    "vorticity", "friction", "damping", *EMITTER_KEYS))
        points = np.zeros((0, 3), np.float32)
        if "block" in c:
            keys = ("counts", "spacing", "origin")
            b = self._need(c["block"], c["block"].keys(keys), keys, "block")
            nx, ny, nz = b["counts"].ints(3, 1)
            z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
            grid = np.stack([x, y, z], -1).reshape(-1, 3) * b["spacing"].positive()
            points = (grid + np.asarray(b["origin"].vec(3, "finite"))).astype(np.float32)
        opts = self._options({k: v for k, v in c.items() if k not in ("block", *EMITTER_KEYS)}, ints=("budget",))
        opts.update(self.emitter(f, c, len(points)))
        if len(points) == 0 and not opts.get("emit_rate"):
            raise f.fail("a fluid needs 'block' {counts, spacing, origin}, an emitter (emit_rate, budget), or both")
        return cressim.Fluid(points, **opts)

    @staticmethod
    def emitter(f: Field, c: dict[str, Field], block: int) -> dict:
        """A fluid's emitter (a bleeding source): each frame up to emit_rate inactive slots start
        on an emit_width-square nozzle at emit_origin (entity frame), moving at emit_velocity."""
        out = {}
        if "emit_rate" in c:
            out["emit_rate"] = c["emit_rate"].int(0)
        if "emit_width" in c:
            out["emit_width"] = c["emit_width"].int(1)
        for k in ("emit_origin", "emit_velocity"):
            if k in c:
                out[k] = c[k].vec(3, "finite")
        budget = c["budget"].int(0) if "budget" in c else 0
        if 0 < budget < block:
            raise c["budget"].fail(f"must hold the block's {block} particles, got {budget}")
        if out.get("emit_rate", 0) > 0:
            if "emit_velocity" in out and not any(out["emit_velocity"]):
                raise c["emit_velocity"].fail("must not be zero: emitted particles leave the nozzle along it")
            if budget <= block:
                raise (c["budget"] if "budget" in c else f).fail(
                    f"an emitter needs a budget above the block's {block} particles (the slots it fills)")
        return out

    def strand(self, f: Field) -> cressim.Strand:
        c = f.keys(("line", "radius", "mass", "fixed", "stretch_compliance", "bend_compliance", "twist_compliance",
                    "damping", "friction", "youngs_modulus", "poisson_ratio", "density"))
        if "line" not in c:
            raise f.fail("a strand needs 'line' {start, end, count}")
        keys = ("start", "end", "count")
        line = self._need(c["line"], c["line"].keys(keys), keys, "line")
        t = np.linspace(0, 1, line["count"].int(2))[:, None]
        points = ((1 - t) * np.asarray(line["start"].vec(3)) + t * np.asarray(line["end"].vec(3))).astype(np.float32)
        fixed = self.selection(c["fixed"], points) if "fixed" in c else None
        opts = self._options({k: v for k, v in c.items() if k not in ("line", "fixed")})
        return cressim.Strand(points, fixed=fixed, **opts)

    def tendons(self, f: Field, entity: dict[str, Field]) -> cressim.Tendons:
        """`disks`: strand particle indices (base first), or {every: k} (particles 0, k, 2k, ... and
        the last); `holes`: [[x, y], ...] per tendon (m, in the disks' frames)."""
        c = f.keys(("disks", "holes", "stiffness"))
        self._need(f, c, ("disks", "holes"), "tendons")
        if "strand" not in entity:
            raise f.fail("tendons need a strand on the same entity (the backbone)")
        line = entity["strand"].items().get("line")
        count = line.items()["count"].int(2) if line is not None and "count" in line.items() else 2
        d = c["disks"]
        if d.is_map():
            every = d.keys(("every",))
            if "every" not in every:
                raise d.fail("give a list of particle indices or {every: k}")
            k = every["every"].int(1)
            disks = list(range(0, count, k)) + ([count - 1] if (count - 1) % k else [])
        else:
            disks = [x.int(0) for x in d.list()]
        holes = [h.vec(2, "finite") for h in c["holes"].list()]
        if not holes:
            raise c["holes"].fail("needs at least one tendon's hole [x, y]")
        opts = self._options({k: v for k, v in c.items() if k == "stiffness"})
        return cressim.Tendons(disks, np.asarray(holes, np.float32), **opts)

    def ultrasound_probe(self, f: Field) -> cressim.UltrasoundProbe:
        """Types and finiteness here; ranges (positive lengths and frequencies, ...) at prepare(),
        which names this file's line of the field."""
        c = f.keys(("kind", "rf_output", *PROBE_INTS, *PROBE_NUMBERS))
        opts = {}
        for k, v in c.items():
            if k == "kind":
                opts[k] = v.str()
                if opts[k] not in ("linear", "sector"):
                    raise v.fail(f"expected linear or sector, got '{opts[k]}'")
            else:
                opts[k] = v.bool() if k == "rf_output" else v.int(1) if k in PROBE_INTS else v.finite()
        return cressim.UltrasoundProbe(**opts)

    def ultrasound_tissue(self, f: Field) -> cressim.UltrasoundTissue:
        """Scatterers: in the region (a rigid tissue), or in the tets of the entity's SoftBody."""
        c = f.keys(("region", "size", "center", "density", "count", "amplitude_mean", "amplitude_std", "attenuation",
                    "impedance", "seed", "inclusions"))
        opts = {}
        for k, v in c.items():
            if k == "region":
                opts[k] = v.str()
                if opts[k] not in REGION_SIZES:
                    raise v.fail(f"expected one of {', '.join(REGION_SIZES)}, got '{opts[k]}'")
            elif k in ("count", "seed"):
                opts[k] = v.int(0)
            elif k == "center":
                opts[k] = v.vec(3, "finite")
            elif k != "size" and k != "inclusions":
                opts[k] = v.finite()
        if "size" in c:
            sizes = REGION_SIZES[opts.get("region", "box")]
            opts["size"] = (*c["size"].vec(sizes, "positive"), 0.0, 0.0)[:3]
        if "inclusions" in c:
            opts["inclusions"] = [self.inclusion(g) for g in c["inclusions"].list()]
        return cressim.UltrasoundTissue(**opts)

    def inclusion(self, f: Field) -> cressim.UltrasoundInclusion:
        keys = ("center", "radius", "amplitude_scale")
        i = self._need(f, f.keys(keys), keys[:2], "an inclusion")
        scale = i["amplitude_scale"].finite() if "amplitude_scale" in i else 0.0
        return cressim.UltrasoundInclusion(i["center"].vec(3, "finite"), i["radius"].positive(), amplitude_scale=scale)

    def look(self, f: Field) -> cressim.Material:
        """A particle object's material: a name from materials (its texture unused) or inline."""
        if isinstance(f.node, yaml.ScalarNode):
            name = f.str()
            if name not in self.materials:
                raise f.fail(f"no material '{name}'; materials: {', '.join(self.materials) or 'none'}")
            opts = {k: v for k, v in self.materials[name].items() if k != "texture"}
        else:
            m = f.keys(("color", "metallic", "roughness", "segmentation_id"))
            opts = self.material({k: v for k, v in m.items() if k != "segmentation_id"})
            if "segmentation_id" in m:
                opts["segmentation_id"] = self.label(m["segmentation_id"].int(1))
        return cressim.Material(**opts)

    def camera(self, f: Field) -> cressim.Camera:
        c = f.keys(("width", "height", "fov_y", "fx", "fy", "cx", "cy", "near", "far", "products"))
        return cressim.Camera(**{k: (v.int(1) if k in ("width", "height") else
                                     [x.str() for x in v.list()] if k == "products" else v.float())
                                 for k, v in c.items()})

    def light(self, f: Field) -> cressim.Light:
        c = f.keys(("kind", "color", "intensity", "ambient", "range", "inner_angle", "outer_angle", "shadows",
                    "shadow_extent", "shadow_resolution"))
        opts = {}
        for k, v in c.items():
            if k == "kind":
                opts[k] = v.str()
            elif k == "color":
                opts[k] = v.vec(3)
            elif k == "shadows":
                opts[k] = v.bool()
            elif k == "shadow_resolution":
                opts[k] = v.int(1)
            else:
                opts[k] = v.float()
        return cressim.Light(**opts)

    def rigid_body(self, f: Field) -> cressim.RigidBody:
        c = f.keys(("mass", "density", "inertia", "kinematic", "linear_damping", "angular_damping"))
        return cressim.RigidBody(**{k: (v.vec(3) if k == "inertia" else v.bool() if k == "kinematic" else v.float())
                                    for k, v in c.items()})

    def collider(self, f: Field) -> cressim.Collider:
        c = f.keys(("shapes", "static_friction", "dynamic_friction", "restitution", "group", "mask"))
        if "shapes" not in c:
            raise f.fail("a collider needs 'shapes'")
        shapes = [self.shape(s) for s in c["shapes"].list()]
        opts = {k: (v.int(0) if k in ("group", "mask") else v.float()) for k, v in c.items() if k != "shapes"}
        return cressim.Collider(shapes, **opts)

    def shape(self, f: Field) -> cressim.Shape:
        kinds = f.keys(("sphere", "box", "capsule", "plane"))
        if len(kinds) != 1:
            raise f.fail("give one of: sphere, box, capsule, plane")
        (kind, g), = kinds.items()
        o = g.keys(("radius", "half_extents", "half_height", "position", "rotation")) if g.is_map() else {}
        pose = {k: o[k].vec(3 if k == "position" else 4) for k in ("position", "rotation") if k in o}
        need = {"sphere": ("radius",), "box": ("half_extents",), "capsule": ("radius", "half_height"), "plane": ()}[kind]
        for k in need:
            if k not in o:
                raise g.fail(f"{kind} needs '{k}'")
        if kind == "sphere":
            return cressim.Shape.sphere(o["radius"].float(), **pose)
        if kind == "box":
            return cressim.Shape.box(o["half_extents"].vec(3), **pose)
        if kind == "capsule":
            return cressim.Shape.capsule(o["radius"].float(), o["half_height"].float(), **pose)
        return cressim.Shape.plane(**pose)


def load_scene(path) -> cressim.World:
    """The World a scene file describes (see the module's docstring for the format)."""
    path = Path(path)
    return _loader(path).load()


@dataclass
class AddedScene:
    labels: dict  # segmentation id drawn -> entity name
    probes: list  # (position, xyzw) of each ultrasound probe entity (as authored, env frame)
    randomization: list  # the file's domain randomization terms, for the env that runs it


def add_scene(world: cressim.World, path, *, segmentation_offset: int = 0, skip: tuple = ("camera",)) -> AddedScene:
    """Adds the entities of scene file `path` to every env of `world` (the twin puts them beside
    its arm), leaving out entities with a component named in `skip` (the twin has its own
    camera); segmentation ids are offset by `segmentation_offset`."""
    loader = _loader(Path(path), segmentation_offset=segmentation_offset, skip=skip)
    loader.load(world)
    return AddedScene(dict(loader.labels), list(loader.probes), list(loader.randomization))


def _loader(path: Path, **options) -> _Loader:
    return _Loader(read_fields(path), path.parent, **options)
