"""Cross-check of generator 4's cloth with Blender's cloth simulator (bpy 5.0.1, Blender as a
Python module): the same motion, the same garment, compared at the motion's last frame.

Per chosen sample of one or more generator-4.0.0 dataset folders, the motion's body frames are
rebuilt exactly as :func:`dressmeup.data.synth.generator4.dress` builds them
(:func:`~dressmeup.data.synth.motion.body_states`, :func:`frame_bodies`, the anchors of
:class:`~dressmeup.data.synth.common.BodyAnchors`), and a Blender scene replays them:

- the body: a mesh whose vertices follow the frames (one relative shape key a frame, keyed
  linearly, so between two frames the body moves linearly as in generator 4), a Collision
  object;
- the garment: the rest mesh generator 4 starts from (same vertices, faces and order) as a
  Cloth object; its anchors are Blender's pin group: each anchored vertex's goal position is
  its anchor point on the frame's body (the cloth mesh's own shape keys) and its pin spring
  has generator 4's anchor stiffness (:func:`blender_settings`);
- the scene runs at generator 4's time step, ``quality`` solver steps a frame, self-collision
  on; frames are stepped one by one (``scene.frame_set``) on one CPU core.

The last frame's garment is compared with the stored sample: per-vertex distance (median,
95th percentile, mm) and, for both results, the plausibility figures of
:func:`dressmeup.data.synth.common.drape_stats` (garment area inside the body, deepest
vertex, self-intersecting faces) and ipctk's exact intersection check
(:meth:`ClothDynamics.intersection_free`); CPU seconds of each engine (generator 4's from its
stats, Blender's ``time.process_time`` around the frames).

Blender's cloth model differs from generator 4's (:func:`blender_settings` maps what maps):
one mass per vertex (generator 4: density times vertex area), edge springs of one stiffness
(generator 4: per edge, by its area and length), angular bending (generator 4: springs between
the opposite corners of a hinge), collision by impulses and repulsion within a distance
(generator 4: IPC barrier and continuous collision detection, never a crossing).

    python benchmarks/studies/generator4_crosscheck.py --data /tmp/g4-gallery --data DIR2 \\
        --samples 12 --out benchmarks/results/studies/DATE-generator4-crosscheck \\
        --picture docs/images/generator4-crosscheck.png
    python benchmarks/studies/generator4_crosscheck.py --data DIR --timing-edge 0.015 --out OUT

writes ``crosscheck.json`` and ``crosscheck.md`` into ``--out`` (``--timing-edge``: Blender
alone on the first chosen garment rebuilt at that edge length, ``timing.json``).

Needs bpy 5.0.1 (the ``crosscheck`` extra; ``pip install --no-deps bpy==5.0.1``, see
docs/synthetic-data.md).
"""

from __future__ import annotations

try:
    # optional: bpy, imported before the toolkit: pymeshlab / open3d load another Embree
    # library, and bpy imported after them misses its own symbols
    import bpy
except ImportError:
    bpy = None

import argparse
import contextlib
import importlib.util
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from dressmeup.data.synth.cloth import ClothModel
from dressmeup.data.synth.common import drape_stats
from dressmeup.data.synth.dynamics import ClothDynamics, DynamicsSettings
from dressmeup.data.synth.generator4 import build, motion_frames
from dressmeup.data.synth.jobs import single_threaded

_spec = importlib.util.spec_from_file_location(
    "synth_g4_figures", Path(__file__).resolve().parents[1] / "perf" / "synth_g4_figures.py")
figures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(figures)

#: Blender's cloth multiplies the scene's gravity by 1e-3 and counts time in frames times
#: ``time_scale``: with the scene's gravity in m/s^2 its time unit is sqrt(1e-3) s, and every
#: force per mass (springs, pins, drag) is scaled by that unit squared
UNIT2 = 1e-3
#: a fold angle (rad) at which the bending energies of the two models are made equal
FOLD = math.pi / 2


def blender_settings(rest_V: np.ndarray, faces: np.ndarray, support: np.ndarray,
                     dyn: DynamicsSettings, dt: float) -> dict:
    """Blender cloth parameters closest to generator 4's :class:`DynamicsSettings` for one
    garment (rest vertices ``(n, 3)``, faces ``(m, 3)``, anchor ``support (n,)``), time step
    ``dt`` (s).

    - ``mass`` (kg a vertex): the mean of density times vertex area;
    - ``tension`` = ``compression`` = ``shear``: Blender's edge spring constant is
      ``tension / avg_len`` (``avg_len`` the mean edge length), set to the mean of generator
      4's ``youngs * A_e / L_e^2`` (N/m), in Blender's units;
    - ``bending``: Blender's angular spring (``k = bending * L * 0.1``, energy
      ``k h theta^2 / 6`` for a hinge of wing height ``h``) made equal in energy to generator
      4's hinge spring (``0.5 k_h (d - D)^2``, ``d = D cos(theta / 2)``) at a fold of
      :data:`FOLD` (generator 4's grows with ``theta^4``, Blender's with ``theta^2``: stiffer
      than generator 4's below that fold, softer above);
    - ``air_damping``: Blender's drag ``0.01 air v`` a vertex equal to the mass-proportional
      ``m damping v``; spring damping 0 (generator 4 has none);
    - pins: generator 4's anchor spring ``anchor_stiffness * area * support`` (N/m) as
      Blender's goal spring ``goal * pin_stiffness / avg_len`` with ``goal = weight^4``
      (weights below Blender's snap to a rigid pin, 0.999);
    - ``time_scale``: ``dt`` in Blender's time unit.

    Returns a dict of those values plus ``pin_weight (n,)``.
    """
    model = ClothModel(rest_V, faces, dyn.cloth())
    ne = model.n_stretch
    avg = float(model.rest_len[:ne].mean())
    unit = math.sqrt(UNIT2)
    k_edge = float(model.spring_k[:ne].mean())
    tension = UNIT2 * k_edge * avg
    # a hinge of two triangles: opposite corners D apart at rest, wings h = D / 2 high
    D = model.rest_len[ne:]
    h = float((D / 2).mean())
    k_h = float(model.spring_k[ne:].mean())
    e_ours = 0.5 * k_h * (float(D.mean()) * (math.cos(FOLD / 2) - 1.0)) ** 2
    bending = UNIT2 * e_ours * 6.0 / (0.1 * avg * h * FOLD ** 2)
    mass = float(model.mass.mean())
    air = 100.0 * mass * dyn.damping * unit
    k_anchor = dyn.anchor_stiffness * model.area * np.asarray(support, np.float64)
    pin_stiffness = UNIT2 * float(k_anchor.max(initial=0.0)) * avg / 0.99
    goal = (UNIT2 * k_anchor * avg / pin_stiffness) if pin_stiffness > 0 else k_anchor * 0
    return {"mass": mass, "tension": tension, "bending": bending, "air_damping": air,
            "pin_stiffness": pin_stiffness, "pin_weight": goal ** 0.25,
            "time_scale": dt / unit, "avg_edge": avg, "gravity": dyn.gravity,
            "contact": dyn.dhat}


@contextlib.contextmanager
def one_core():
    """Every thread of this process (Blender's task pool included) on one CPU core, then
    back (Linux: the affinity is per thread; threads started inside inherit it)."""
    before = os.sched_getaffinity(0)
    core = {min(before)}
    tasks = [int(t) for t in os.listdir("/proc/self/task")]
    for t in tasks:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(t, core)
    try:
        yield
    finally:
        for t in [int(t) for t in os.listdir("/proc/self/task")]:
            with contextlib.suppress(OSError):
                os.sched_setaffinity(t, before)


def _mesh_object(name: str, V: np.ndarray, F: np.ndarray):
    """A Blender mesh object of vertices ``V (n, 3)`` and triangles ``F (m, 3)`` (same order)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata(V.tolist(), [], np.asarray(F, np.int64).tolist())
    me.update()
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _key_frames(ob, frames: list[np.ndarray]) -> None:
    """Animate ``ob``'s vertices through ``frames`` (Blender frame ``k + 1`` shows
    ``frames[k]``, linear in between): a basis key of ``frames[0]`` and one relative key a
    later frame, weight 1 on its frame and 0 on the neighbouring ones."""
    ob.shape_key_add(name="basis", from_mix=False)
    for k in range(1, len(frames)):
        key = ob.shape_key_add(name=f"f{k}", from_mix=False)
        key.points.foreach_set("co", np.asarray(frames[k], np.float32).ravel())
        for f, v in ((k, 0.0), (k + 1, 1.0), (k + 2, 0.0)):
            if 1 <= f <= len(frames):
                key.value = v
                key.keyframe_insert("value", frame=f)


def blender_cloth(rest_V: np.ndarray, faces: np.ndarray, bodies: list[np.ndarray],
                  body_F: np.ndarray, up: np.ndarray, dyn: DynamicsSettings, dt: float,
                  support: np.ndarray | None = None, anchors: list[np.ndarray] | None = None,
                  quality: int = 10, collision_quality: int = 4,
                  bending_factor: float = 1.0, on_frame=None) -> tuple[np.ndarray, dict]:
    """Simulate the cloth ``rest_V (n, 3)``, ``faces (m, 3)`` with Blender through the body
    frames ``bodies`` (``(b, 3)`` each, frame 0 the start; faces ``body_F (c, 3)``), gravity
    along ``-up``, time step ``dt`` (s), from rest.

    ``support (n,)`` and ``anchors`` (per frame ``(n, 3)`` anchor points) pin the supported
    vertices to their anchors (:func:`blender_settings`); ``quality``: Blender's solver steps a
    frame; ``collision_quality``: its collision passes a step; ``bending_factor`` multiplies
    the mapped bending stiffness (a diagnosis of the bending mapping; 1: as mapped). Runs in a
    fresh, empty Blender scene on one CPU core.

    Returns ``(vertices (n, 3) float64 at the last frame, info)``; info: ``cpu_s`` (process CPU
    time of the frames), ``wall_s``, ``frames``, ``settings`` (the mapped parameters).
    """
    if bpy is None:
        raise RuntimeError("Blender's cloth needs bpy 5.0.1 (the crosscheck extra)")
    n = len(rest_V)
    support = np.zeros(n) if support is None else np.asarray(support, np.float64)
    bs = blender_settings(rest_V, faces, support, dyn, dt)
    bs["bending"] *= float(bending_factor)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    scene = bpy.context.scene
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 1
    scene.render.fps, scene.render.fps_base = 30, 1.0
    last = len(bodies)
    scene.frame_start, scene.frame_end = 1, last
    up = np.asarray(up, np.float64) / np.linalg.norm(up)
    scene.gravity = tuple(-bs["gravity"] * up)
    scene.use_gravity = True

    body = _mesh_object("body", np.asarray(bodies[0]), body_F)
    _key_frames(body, bodies)
    body.modifiers.new("collision", "COLLISION")
    body.collision.thickness_outer = 0.001
    body.collision.cloth_friction = 0.0
    body.collision.damping = 0.0

    cloth = _mesh_object("garment", np.asarray(rest_V), faces)
    pinned = np.flatnonzero(bs["pin_weight"] > 0)
    if anchors is not None and len(pinned):
        goals = []
        for A in anchors:
            G = np.array(rest_V, np.float64)
            G[pinned] = np.asarray(A)[pinned]
            goals.append(G)
        goals[0] = np.array(rest_V, np.float64)  # the start is the garment as designed
        _key_frames(cloth, goals)
        group = cloth.vertex_groups.new(name="pin")
        for i in pinned:
            group.add([int(i)], float(bs["pin_weight"][i]), "REPLACE")
    mod = cloth.modifiers.new("cloth", "CLOTH")
    s = mod.settings
    s.quality = int(quality)
    s.mass = bs["mass"]
    s.time_scale = bs["time_scale"]
    s.bending_model = "ANGULAR"
    s.tension_stiffness = s.compression_stiffness = s.shear_stiffness = bs["tension"]
    s.bending_stiffness = bs["bending"]
    s.tension_damping = s.compression_damping = s.shear_damping = s.bending_damping = 0.0
    s.air_damping = bs["air_damping"]
    if anchors is not None and len(pinned):
        s.vertex_group_mass = "pin"
        s.pin_stiffness = bs["pin_stiffness"]
    c = mod.collision_settings
    c.use_collision = True
    c.distance_min = max(bs["contact"] - 0.001, 0.001)  # plus the body's 1 mm thickness
    c.collision_quality = int(collision_quality)
    c.friction = 0.0
    c.use_self_collision = True
    c.self_distance_min = max(bs["contact"], 0.001)
    c.self_friction = 0.0
    mod.point_cache.frame_start, mod.point_cache.frame_end = 1, last

    with one_core():
        t0, w0 = time.process_time(), time.perf_counter()
        for f in range(1, last + 1):
            scene.frame_set(f)
            if on_frame is not None:
                on_frame(f - 1)
        cpu_s, wall_s = time.process_time() - t0, time.perf_counter() - w0
    ev = cloth.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    if len(ev.vertices) != n:
        raise RuntimeError(f"Blender's cloth has {len(ev.vertices)} vertices, not {n}")
    co = np.zeros(3 * n, np.float32)
    ev.vertices.foreach_get("co", co)
    info = {"cpu_s": cpu_s, "wall_s": wall_s, "frames": last - 1, "quality": int(quality),
            "collision_quality": int(collision_quality),
            "settings": {k: v for k, v in bs.items() if k != "pin_weight"},
            "pinned": int(len(pinned))}
    return co.reshape(n, 3).astype(np.float64), info


def motion_inputs(kit, built, shape: np.ndarray, pose: np.ndarray, settings) -> tuple:
    """The body frames ``(b, 3)`` and anchor points ``(n, 3)`` of every frame of the motion
    :func:`generator4.dress` simulates for ``built`` to ``shape``, ``pose``."""
    bodies, anchors = motion_frames(kit, built, shape, pose, settings)
    return bodies, [anchors.points(B) for B in bodies]


def plausibility(V: np.ndarray, built, body: np.ndarray, kit, dyn: DynamicsSettings) -> dict:
    """drape_stats of the garment ``V`` on the final ``body`` and ipctk's exact check."""
    st = drape_stats(V, built.faces, built.vertices, body, kit.faces)
    cd = ClothDynamics(built.vertices, built.faces, kit.faces, built.frame.up, dyn)
    st["intersection_free"] = bool(cd.intersection_free(V, body))
    return st


def crosscheck(root: Path, item: dict, quality: int, collision_quality: int,
               bending_factor: float = 1.0) -> dict:
    """Blender on one stored sample and the comparison (module docstring)."""
    with single_threaded():
        settings, kit, built, body, V4 = figures.replay_inputs(root, item)
        if V4.shape != built.vertices.shape:
            raise RuntimeError(f"{item['id']}: rebuilt garment has {len(built.vertices)} "
                               f"vertices, the stored one {len(V4)}")
        bodies, anchors = motion_inputs(kit, built, body["shape"], body["pose"], settings)
        VB, info = blender_cloth(built.vertices, built.faces, bodies, kit.faces,
                                 built.frame.up, settings.dynamics, settings.motion.dt,
                                 built.support, anchors, quality, collision_quality,
                                 bending_factor)
        d = np.sqrt(np.sum((VB - V4) ** 2, axis=1)) * 1000
        g4 = plausibility(V4, built, bodies[-1], kit, settings.dynamics)
        bl = plausibility(VB, built, bodies[-1], kit, settings.dynamics)
    st = item["stats"]
    return {"id": item["id"], "data": str(root), "type": item["garment"]["type"],
            "fit": item["garment"].get("fit"), "family": item["family"],
            "vertices": int(len(V4)), "faces": int(len(built.faces)),
            "median_mm": float(np.median(d)), "p95_mm": float(np.percentile(d, 95)),
            "max_mm": float(d.max()), "distance_mm": d.round(3).tolist(),
            "generator4": {**g4, "cpu_s": st["cpu_s"]},
            "blender": {**bl, **{k: v for k, v in info.items()}},
            "blender_vertices": VB.round(6).tolist(), "load": figures.load()}


def pick(items: list[dict], n: int) -> list[dict]:
    """``n`` samples: a sitting one first, then one of each garment type (in order of first
    appearance), then round-robin over the types, each time the sample of a pose family not
    yet chosen for that type when there is one."""
    types = list(dict.fromkeys(s["garment"]["type"] for s in items))
    left = list(items)
    out: list[dict] = []
    sitting = [s for s in left if s["family"] == "sitting"]
    if sitting:
        out.append(sitting[0])
        left.remove(sitting[0])
    while left and len(out) < n:
        for t in types:
            if len(out) >= n:
                break
            cand = [s for s in left if s["garment"]["type"] == t]
            if not cand:
                continue
            seen = {s["family"] for s in out if s["garment"]["type"] == t}
            s = next((c for c in cand if c["family"] not in seen), cand[0])
            out.append(s)
            left.remove(s)
    return out


def table(rows: list[dict]) -> str:
    """Markdown: one row a sample, then the medians over samples."""
    lines = ["| sample | type | pose family | vertices | median mm | p95 mm | inside % G4 / "
             "Blender | deepest mm G4 / Blender | self-int. faces G4 / Blender | ipctk free "
             "G4 / Blender | CPU s G4 / Blender |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        g, b = r["generator4"], r["blender"]
        lines.append(
            f"| {r['id']} ({Path(r['data']).name}) | {r['type']} | {r['family']} | "
            f"{r['vertices']} | {r['median_mm']:.1f} | {r['p95_mm']:.1f} | "
            f"{g['inside_area_pct']:.2f} / {b['inside_area_pct']:.2f} | "
            f"{g['deepest_mm']:.1f} / {b['deepest_mm']:.1f} | "
            f"{g['self_intersecting_faces']} / {b['self_intersecting_faces']} | "
            f"{g['intersection_free']} / {b['intersection_free']} | "
            f"{g['cpu_s']:.0f} / {b['cpu_s']:.0f} |")
    if rows:
        def med(f):
            return float(np.median([f(r) for r in rows]))
        lines += ["", f"Medians over {len(rows)} samples: per-vertex distance median "
                  f"{med(lambda r: r['median_mm']):.1f} mm, p95 {med(lambda r: r['p95_mm']):.1f}"
                  f" mm; inside area {med(lambda r: r['generator4']['inside_area_pct']):.2f} % "
                  f"(generator 4) / {med(lambda r: r['blender']['inside_area_pct']):.2f} % "
                  f"(Blender); self-intersecting faces "
                  f"{med(lambda r: r['generator4']['self_intersecting_faces']):.0f} / "
                  f"{med(lambda r: r['blender']['self_intersecting_faces']):.0f}; CPU s "
                  f"{med(lambda r: r['generator4']['cpu_s']):.0f} / "
                  f"{med(lambda r: r['blender']['cpu_s']):.0f}; samples with median > 10 mm: "
                  f"{sum(r['median_mm'] > 10 for r in rows)} of {len(rows)}."]
    return "\n".join(lines) + "\n"


def picture(rows: list[dict], items: dict[str, dict], path: Path) -> None:
    """Per sample, front view: generator 4's garment and Blender's, each coloured by the
    per-vertex distance between the two (0-50 mm, viridis), the final body grey."""
    # heavy: matplotlib through viz (~0.3 s to import)
    from matplotlib import colormaps

    from dressmeup.viz.contact_sheet import MeshLayer, render_contact_sheet

    cmap = colormaps["viridis"]
    cells, titles = [], []
    for r in rows:
        item = items[r["id"] + r["data"]]
        with single_threaded():
            settings, kit, built, body, V4 = figures.replay_inputs(Path(r["data"]), item)
        B = kit.surface(body["shape"], body["pose"])
        d = np.asarray(r["distance_mm"])[built.faces].mean(1)
        col = cmap(np.clip(d / 50.0, 0, 1))[:, :3]
        VB = np.asarray(r["blender_vertices"])
        for name, V in (("generator 4", V4), ("Blender", VB)):
            cells.append([MeshLayer(B, kit.faces, (0.72, 0.72, 0.72)),
                          MeshLayer(V, built.faces, face_colors=col)])
            titles.append(f"{r['id']} {name}\n{r['type']}, {r['family']}: "
                          f"{r['median_mm']:.0f}/{r['p95_mm']:.0f} mm")
    path.parent.mkdir(parents=True, exist_ok=True)
    render_contact_sheet(cells, path, right=np.array([1.0, 0, 0]), up=np.array([0, 1.0, 0]),
                         ncols=6, titles=titles, cell_size=2.2,
                         suptitle="generator 4 vs Blender's cloth, same motion: garment "
                                  "coloured by the distance between the two (0-50 mm); "
                                  "titles: median/p95")


def timing(root: Path, item: dict, edge: float, frames: int, quality: int,
           collision_quality: int) -> dict:
    """Blender alone on ``item``'s garment rebuilt at ``edge`` (m): the sample's motion, its
    first ``frames`` frames (0: all); seconds a frame and vertices."""
    with single_threaded():
        settings, kit, built, body, _ = figures.replay_inputs(root, item)
        g = item["garment"]
        fine = build(kit, g["type"], g["params"], built.design_shape, edge)
        bodies, anchors = motion_inputs(kit, fine, body["shape"], body["pose"], settings)
        if frames:
            bodies, anchors = bodies[: frames + 1], anchors[: frames + 1]
        VB, info = blender_cloth(fine.vertices, fine.faces, bodies, kit.faces, fine.frame.up,
                                 settings.dynamics, settings.motion.dt, fine.support, anchors,
                                 quality, collision_quality)
        st = plausibility(VB, fine, bodies[-1], kit, settings.dynamics)
    return {"id": item["id"], "type": g["type"], "edge_length": edge,
            "vertices": int(len(fine.vertices)), "frames": info["frames"],
            "cpu_s": info["cpu_s"], "wall_s": info["wall_s"],
            "cpu_s_a_frame": info["cpu_s"] / info["frames"], "plausibility": st,
            "quality": quality, "load": figures.load()}


def _compare(path: Path, other: Path) -> int:
    """Print, per sample in both runs, the per-vertex distance (mm) between their Blender
    results and the two runs' distances to generator 4."""
    mine = {(r["data"], r["id"]): r for r in json.loads(path.read_text())["samples"]}
    theirs = json.loads(other.read_text())
    out = []
    for r in theirs["samples"]:
        m = mine.get((r["data"], r["id"]))
        if m is None:
            continue
        d = np.sqrt(np.sum((np.asarray(m["blender_vertices"])
                            - np.asarray(r["blender_vertices"])) ** 2, axis=1)) * 1000
        out.append({"id": r["id"], "median_mm": float(np.median(d)),
                    "p95_mm": float(np.percentile(d, 95)), "max_mm": float(d.max()),
                    "to_generator4": [m["median_mm"], m["p95_mm"], r["median_mm"], r["p95_mm"]],
                    "cpu_s": [m["blender"]["cpu_s"], r["blender"]["cpu_s"]]})
        print(json.dumps(out[-1]), flush=True)
    (path.parent / "compare.json").write_text(json.dumps(
        {"this": str(path), "other": str(other), "samples": out}, indent=1))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, action="append", required=True,
                    help="a generator-4.0.0 dataset folder (repeatable)")
    ap.add_argument("--samples", type=int, default=12)
    ap.add_argument("--only", nargs="*", default=None, help="sample ids to run (else --samples)")
    ap.add_argument("--quality", type=int, default=10, help="Blender's steps a frame")
    ap.add_argument("--collision-quality", type=int, default=4)
    ap.add_argument("--bending-factor", type=float, default=1.0,
                    help="multiply the mapped bending stiffness (diagnosis)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--picture", type=Path, default=None)
    ap.add_argument("--timing-edge", type=float, default=0.0,
                    help="time Blender alone on the first chosen garment at this edge (m)")
    ap.add_argument("--timing-frames", type=int, default=0)
    ap.add_argument("--redraw", action="store_true",
                    help="rewrite the table and the picture from OUT/crosscheck.json")
    ap.add_argument("--compare-to", type=Path, default=None,
                    help="another run's crosscheck.json: distance between the two Blender "
                         "results of each sample both ran (Blender's own sensitivity)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.compare_to is not None:
        return _compare(a.out / "crosscheck.json", a.compare_to)
    items = []
    for root in a.data:
        _, samples, _ = figures.read_samples(root)
        items += [{**s, "root": root} for s in samples]
    chosen = ([s for s in items if s["id"] in set(a.only)] if a.only
              else pick(items, a.samples))
    print(f"{len(chosen)} samples; load {figures.load()}", flush=True)
    if a.timing_edge:
        s = chosen[0]
        t = timing(s["root"], s, a.timing_edge, a.timing_frames, a.quality,
                   a.collision_quality)
        (a.out / "timing.json").write_text(json.dumps(t, indent=1))
        print(json.dumps(t), flush=True)
        return 0
    rows = []
    jpath = a.out / "crosscheck.json"
    if a.redraw:
        rows = json.loads(jpath.read_text())["samples"]
        chosen = [s for r in rows for s in items if s["id"] == r["id"]
                  and str(s["root"]) == r["data"]]
    for s in ([] if a.redraw else chosen):
        r = crosscheck(s["root"], s, a.quality, a.collision_quality, a.bending_factor)
        rows.append(r)
        print(json.dumps({k: v for k, v in r.items()
                          if k not in ("distance_mm", "blender_vertices")}, default=float),
              flush=True)
        jpath.write_text(json.dumps({"samples": rows, "quality": a.quality,
                                     "collision_quality": a.collision_quality,
                                     "bending_factor": a.bending_factor}, default=float))
    md = table(rows)
    (a.out / "crosscheck.md").write_text(md)
    print(md)
    if a.picture is not None:
        picture(rows, {s["id"] + str(s["root"]): s for s in chosen}, a.picture)
    return 0


if __name__ == "__main__":
    with contextlib.suppress(BrokenPipeError):
        raise SystemExit(main())
