"""HTML: a single self-contained web page to look at a scene in any browser, offline.

The page holds everything it needs: three.js (r160, MIT licence, vendored under
``exporters/vendor/`` and inlined through an import map of ``data:`` URLs), its
OrbitControls, and the scene's geometry, the same as the GLB's (:func:`glb.build`):
each mesh once as base64 arrays (float32 positions in metres, 8-bit sRGB vertex colours,
uint32 indices) and each node as a 4x4 matrix, so repeated assets are drawn as
instanced meshes. No network access is needed at view time.

The camera orbits the scene (drag to turn, scroll to zoom, right-drag to pan; Z is up);
clicking a thing shows its node name (a placement's id, ``zone/<id>``, ``agent/<id>``
...). A legend lists the zone kinds in the scene with their colours
(:data:`~citygen.exporters.ZONE_COLORS`), then agents and the task's markers.
Lighting is set so that ground seen from above shows its zone's colour exactly.

The same scene always gives the same bytes.

>>> from citygen.exporters import html
>>> page = html.to_html("examples/street_corner.json")
>>> page.startswith("<!DOCTYPE html>"), "OrbitControls" in page, "https://" in page
(True, True, False)
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from citygen.errors import ExportError
from citygen.exporters import ZONE_COLORS
from citygen.exporters.options import AUTO, check_options, output_name, scene_dir_of
from citygen.exporters.scene_graph import AGENT_COLORS, GOAL_COLOR, START_COLOR, build
from citygen.io import write_atomic
from citygen.spec.scene import Scene
from citygen.spec.surfaces import ZONE_KINDS

THREE_VERSION = "0.160.0"
BACKGROUND = "#dde6ee"

_OPTIONS = ("name", "scene_dir", "resolution", "title", "legend")


def _vendor(name: str) -> bytes:
    path = resources.files("citygen.exporters").joinpath("vendor", name)
    try:
        return path.read_bytes()
    except OSError:
        raise ExportError(f"html export: the vendored file vendor/{name} is missing from citygen") from None


def _data_url(source: bytes) -> str:
    return "data:text/javascript;base64," + base64.b64encode(source).decode("ascii")


def _b64(array: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _mesh_payload(mesh: trimesh.Trimesh) -> dict[str, Any]:
    colours = np.asarray(mesh.visual.vertex_colors, dtype=np.uint8)[:, :3]
    return {
        "position": _b64(np.asarray(mesh.vertices, dtype="<f4")),
        "color": _b64(colours),
        "index": _b64(np.asarray(mesh.faces, dtype="<u4")),
    }


def scene_payload(
    scene: Scene | str | Path, *, scene_dir: str | Path | None = None, resolution: float | str | None = AUTO
) -> dict[str, Any]:
    """The data the page draws: meshes, instances and legend, as JSON-ready values."""
    model, folder = scene_dir_of(scene, {"scene_dir": scene_dir})
    graph = build(model, scene_dir=folder, resolution=resolution, y_up=False, fmt="html")
    names = list(graph.geometry)
    instances: dict[str, list] = {name: [] for name in names}
    for node in graph.graph.nodes_geometry:  # insertion order: deterministic
        matrix, geometry = graph.graph[node]
        instances[geometry].append([node, [round(float(x), 6) + 0.0 for x in np.asarray(matrix).ravel()]])
    meshes = [
        {"name": name, **_mesh_payload(graph.geometry[name]), "instances": instances[name]} for name in names
    ]

    kinds = {z.kind for z in model.zones}
    legend = [[kind, ZONE_COLORS[kind]] for kind in ZONE_KINDS if kind in kinds]
    agents = {a.kind for a in model.agents}
    legend += [[kind, AGENT_COLORS[kind]] for kind in AGENT_COLORS if kind in agents]
    if model.task is not None:
        legend += [["start", START_COLOR], ["goal", GOAL_COLOR]]
    (x0, y0), (x1, y1) = model.bounds.min, model.bounds.max
    box = [[round(float(x), 6) + 0.0 for x in corner] for corner in graph.bounds]
    return {"bounds": [x0, y0, x1, y1], "box": box, "meshes": meshes, "legend": legend}


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<!-- three.js {three_version}: The MIT License. Copyright (c) 2010-2023 three.js authors.
{license}-->
<style>
html, body {{ margin: 0; height: 100%; overflow: hidden; background: {background};
  font: 13px/1.35 system-ui, sans-serif; color: #1b1b1b; }}
canvas {{ display: block; }}
#legend {{ position: absolute; top: 10px; left: 10px; max-width: 190px; padding: 8px 10px;
  background: rgba(255, 255, 255, 0.88); border-radius: 6px; box-shadow: 0 1px 4px rgba(0, 0, 0, 0.25); }}
#legend h1 {{ font-size: 13px; margin: 0 0 6px; }}
#legend div {{ display: flex; align-items: center; gap: 6px; }}
#legend span {{ width: 14px; height: 14px; border: 1px solid rgba(0, 0, 0, 0.35); flex: none; }}
#info {{ position: absolute; bottom: 8px; left: 10px; padding: 3px 8px; border-radius: 4px;
  background: rgba(255, 255, 255, 0.8); }}
</style>
<script type="importmap">
{importmap}
</script>
</head>
<body>
<div id="legend"{legend_hidden}><h1>{title}</h1>{legend}</div>
<div id="info">drag to orbit, scroll to zoom, right-drag to pan; click a thing for its name</div>
<script type="application/json" id="scene-data">{data}</script>
<script type="module">
{script}
</script>
</body>
</html>
"""

_SCRIPT = """\
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const data = JSON.parse(document.getElementById("scene-data").textContent);
const bytes = (b64) => Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));

const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.prepend(renderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color("__BACKGROUND__");
// Lambert shading without the legacy factor: light of intensity PI gives a face turned
// to it its own colour. Ambient 0.45 plus the sun's 0.55 at ground level: ground seen
// from above shows exactly its zone's colour; walls and risers are darker.
const sun = new THREE.Vector3(-0.3, -0.5, 1.0).normalize();
scene.add(new THREE.AmbientLight(0xffffff, 0.45 * Math.PI));
const light = new THREE.DirectionalLight(0xffffff, (0.55 / sun.z) * Math.PI);
light.position.copy(sun);
scene.add(light);

const [x0, y0, x1, y1] = data.bounds;
const root = new THREE.Group();
root.position.set(-(x0 + x1) / 2, -(y0 + y1) / 2, 0);  // centred on the bounds: float32 stays precise
scene.add(root);

const material = new THREE.MeshLambertMaterial({
  vertexColors: true, flatShading: true, side: THREE.DoubleSide });
// The terrain solid lies just below the zones' surfaces: pushed back in depth, it never
// shows through them, however far the camera.
const behind = material.clone();
behind.polygonOffset = true;
behind.polygonOffsetFactor = 4;
behind.polygonOffsetUnits = 4;
const picked = [];
const colour = new THREE.Color();
for (const mesh of data.meshes) {
  const geometry = new THREE.BufferGeometry();
  const position = new Float32Array(bytes(mesh.position).buffer);
  geometry.setAttribute("position", new THREE.BufferAttribute(position, 3));
  const srgb = bytes(mesh.color);
  const linear = new Float32Array(srgb.length);
  for (let i = 0; i < srgb.length; i += 3) {
    colour.setRGB(srgb[i] / 255, srgb[i + 1] / 255, srgb[i + 2] / 255, THREE.SRGBColorSpace);
    linear[i] = colour.r; linear[i + 1] = colour.g; linear[i + 2] = colour.b;
  }
  geometry.setAttribute("color", new THREE.BufferAttribute(linear, 3));
  geometry.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(mesh.index).buffer), 1));
  const matrix = new THREE.Matrix4();
  let object;
  if (mesh.instances.length === 1) {
    object = new THREE.Mesh(geometry, mesh.name === "terrain" ? behind : material);
    object.matrixAutoUpdate = false;
    object.matrix.set(...mesh.instances[0][1]);
  } else {
    object = new THREE.InstancedMesh(geometry, material, mesh.instances.length);
    mesh.instances.forEach(([, m], i) => object.setMatrixAt(i, matrix.set(...m)));
    object.computeBoundingSphere();
  }
  object.userData.names = mesh.instances.map(([name]) => name);
  root.add(object);
  picked.push(object);
}

// Frame the whole scene, seen from the south at 50 degrees above the horizon.
const [lo, hi] = data.box;
const centre = new THREE.Vector3(
  (lo[0] + hi[0] - x0 - x1) / 2, (lo[1] + hi[1] - y0 - y1) / 2, (lo[2] + hi[2]) / 2);
const radius = Math.max(0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]), 0.5);
const aspect = window.innerWidth / window.innerHeight;
const camera = new THREE.PerspectiveCamera(45, aspect, radius / 200, radius * 40);
const half = Math.min(Math.PI / 8, Math.atan(Math.tan(Math.PI / 8) * aspect));
const distance = radius / Math.sin(half);
const up = THREE.MathUtils.degToRad(50);
camera.up.set(0, 0, 1);
camera.position.set(0, -distance * Math.cos(up), distance * Math.sin(up)).add(centre);
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.copy(centre);
controls.update();
const render = () => renderer.render(scene, camera);
controls.addEventListener("change", render);
window.addEventListener("resize", () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  render();
});

const ray = new THREE.Raycaster();
const info = document.getElementById("info");
renderer.domElement.addEventListener("click", (event) => {
  const pointer = new THREE.Vector2(
    (event.clientX / window.innerWidth) * 2 - 1, -(event.clientY / window.innerHeight) * 2 + 1);
  ray.setFromCamera(pointer, camera);
  const hit = ray.intersectObjects(picked, false)[0];
  if (hit) {
    const names = hit.object.userData.names;
    info.textContent = names[hit.instanceId ?? 0];
  }
});
render();
"""


def to_html(
    scene: Scene | str | Path,
    *,
    scene_dir: str | Path | None = None,
    resolution: float | str | None = AUTO,
    title: str | None = None,
    legend: bool = True,
) -> str:
    """The page's text (see the module docstring). ``title`` defaults to the scene's split
    and index, else "citygen scene"; ``legend=False`` hides
    the legend. ``resolution`` (m) is the cell size of rough tiles' meshes."""
    model, folder = scene_dir_of(scene, {"scene_dir": scene_dir})
    if title is None:
        if model.meta.split is not None and model.meta.index is not None:
            title = f"{model.meta.split} #{model.meta.index}"
        else:
            title = "citygen scene"
    if not isinstance(title, str):
        raise ExportError(f"html export: expected a string for 'title', got {title!r}")
    if not isinstance(legend, bool):
        raise ExportError(f"html export: expected true or false for 'legend', got {legend!r}")
    payload = scene_payload(model, scene_dir=folder, resolution=resolution)
    rows = "".join(
        f'<div><span style="background:{colour}"></span>{html.escape(label)}</div>'
        for label, colour in payload["legend"]
    )
    importmap = {
        "imports": {
            "three": _data_url(_vendor("three.module.min.js")),
            "three/addons/controls/OrbitControls.js": _data_url(_vendor("OrbitControls.js")),
        }
    }
    data = json.dumps(payload, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    licence = _vendor("LICENSE").decode("utf-8").replace("--", "- -")
    return _PAGE.format(
        title=html.escape(title),
        three_version=THREE_VERSION,
        license=licence,
        background=BACKGROUND,
        importmap=json.dumps(importmap, indent=1),
        legend=rows,
        legend_hidden="" if legend else " hidden",
        data=data,
        script=_SCRIPT.replace("__BACKGROUND__", BACKGROUND),
    )


def export(scene: Scene | str | Path, out_dir: str | Path, **options: Any) -> list[Path]:
    """Write ``<out_dir>/<name>.html``; returns ``[that path]``.

    Options: ``name`` (default: the scene file's stem, ``<split>-<index>`` or ``scene``),
    ``scene_dir`` (the folder mesh placements are relative to, for a scene model),
    ``resolution`` (m, default :data:`~citygen.exporters.options.AUTO`), ``title`` and ``legend`` (see
    :func:`to_html`).
    """
    check_options(options, _OPTIONS, "html")
    name = output_name(scene, options, "html")
    text = to_html(scene, **{k: v for k, v in options.items() if k != "name"})
    path = Path(out_dir) / f"{name}.html"
    write_atomic(path, text.encode("utf-8"))
    return [path]
