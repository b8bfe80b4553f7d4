"""The plan viewer: a self-contained page holding every frame and action label, under the size
budget, whose poses are the plan's; a PNG snapshot of the requested size that shows something;
the command's errors."""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from tests.support import CLUTTER, EXAMPLES, FIXTURES, TABLETOP, tmpc_here

PLANS = FIXTURES / "plans"


@pytest.fixture(scope="module")
def tabletop():
    from tmpc.compiler.artifact import open_world
    return open_world(TABLETOP, with_program=False)


@pytest.fixture(scope="module")
def plan():
    return json.loads((PLANS / "tabletop.json").read_text())


@pytest.fixture(scope="module")
def page(tabletop, plan, tmp_path_factory):
    from tmpc.runtime.viewer import write_html
    out = tmp_path_factory.mktemp("page") / "plan.html"
    size = write_html(tabletop, plan, out)
    text = out.read_text(encoding="utf-8")
    assert size == len(text.encode("utf-8"))
    return text


def embedded(text: str) -> dict:
    m = re.search(r'<script id="plan-data" type="application/json">(.*?)</script>', text, re.S)
    return json.loads(m.group(1))


def decode(s: str, dtype) -> np.ndarray:
    return np.frombuffer(base64.b64decode(s), dtype)


def test_page_is_self_contained(page):
    assert page.startswith("<!doctype html>")
    assert "http://" not in page and "https://" not in page
    assert not re.search(r"<(script|img|link|iframe)[^>]*\s(src|href)=", page)
    assert "getContext(\"webgl2\"" in page          # the renderer is inline


def test_page_holds_every_frame_state_and_action(page, plan):
    data = embedded(page)
    nodes, count = len(data["nodes"]), data["frames"]["count"]
    times = decode(data["frames"]["t"], "<f4")
    assert len(times) == count and np.all(np.diff(times) >= 0)
    assert decode(data["frames"]["pos"], "<f4").size == count * nodes * 3
    assert decode(data["frames"]["rot"], "<i2").size == count * nodes * 4
    assert [s["index"] for s in data["states"]] == list(range(len(plan["states"])))
    assert [s["action"] for s in data["states"]] == [s["action"] for s in plan["states"]]
    assert count > len(plan["states"])              # motions are sampled between states
    for action in plan["actions"]:
        assert action in page
    assert {"red_cube", "blue_cube", "bench", "tray", "panda_link0"} <= set(data["nodes"])


def test_page_poses_are_the_plans(page, plan):
    """At each state's frame, every object sits where the plan puts it (held ones included)."""
    data = embedded(page)
    nodes, count = data["nodes"], data["frames"]["count"]
    pos = decode(data["frames"]["pos"], "<f4").reshape(count, len(nodes), 3)
    rot = decode(data["frames"]["rot"], "<i2").reshape(count, len(nodes), 4) / 32767
    for st, ps in zip(data["states"], plan["states"]):
        for name, pose in ps["object_poses"].items():
            k = nodes.index(name)
            assert np.allclose(pos[st["frame"], k], pose["translation"], atol=1e-5)
            q, want = rot[st["frame"], k], np.asarray(pose["rotation"])
            assert min(np.abs(q - want).max(), np.abs(q + want).max()) < 1e-3


def test_held_cube_rides_with_the_hand_between_states(page, plan):
    """Mid-motion frames carry the held cube at a fixed offset from the hand."""
    data = embedded(page)
    nodes, count = data["nodes"], data["frames"]["count"]
    pos = decode(data["frames"]["pos"], "<f4").reshape(count, len(nodes), 3)
    a, b = data["states"][2]["frame"], data["states"][3]["frame"]   # red_cube held from 2 to 3
    assert b - a > 2
    cube, hand = nodes.index("red_cube"), nodes.index("panda_hand")
    gap = np.linalg.norm(pos[a:b + 1, cube] - pos[a:b + 1, hand], axis=1)
    assert np.ptp(gap) < 1e-4 and np.linalg.norm(pos[b, cube] - pos[a, cube]) > 0.05


def test_script_parses(page, tmp_path):
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    script = page.split("<script>\n", 1)[1].rsplit("</script>", 1)[0]
    js = tmp_path / "viewer.js"
    js.write_text(script)
    r = subprocess.run([node, "--check", str(js)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_pr2_clutter_page_is_small(tmp_path):
    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.viewer import write_html
    plan = json.loads((PLANS / "clutter.json").read_text())
    size = write_html(open_world(CLUTTER, with_program=False), plan, tmp_path / "c.html")
    assert size < 5_000_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.html"]     # no temporary left


def test_a_warm_page_reads_the_urdf_and_meshes_from_the_cache(tmp_path):
    """A world's second page imports neither yourdfpy nor trimesh (the validator's read of the
    URDF and the decoded meshes come from the cache) and is the same page; damaged entries are
    made again."""
    code = ("import json, sys\n"
            "from tmpc.compiler.artifact import open_world\n"
            "from tmpc.runtime.viewer import write_html\n"
            f"plan = json.loads(open({str(PLANS / 'tabletop.json')!r}).read())\n"
            f"write_html(open_world({str(TABLETOP)!r}, with_program=False), plan, sys.argv[1])\n"
            "print(json.dumps([m for m in ('yourdfpy', 'trimesh') if m in sys.modules]))\n")
    env = {**os.environ, "TMPC_CACHE_DIR": str(tmp_path / "cache")}

    def page(name: str) -> tuple[list, bytes]:
        r = subprocess.run([sys.executable, "-c", code, str(tmp_path / name)], env=env,
                           capture_output=True, text=True, timeout=300, check=False)
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout.strip().splitlines()[-1]), (tmp_path / name).read_bytes()

    cold, first = page("a.html")
    assert cold == ["yourdfpy", "trimesh"]
    assert page("b.html") == ([], first)
    entries = list((tmp_path / "cache" / "viewer").iterdir())
    assert any(e.name.startswith("urdf-") for e in entries)
    assert any(e.name.startswith("mesh-") for e in entries)
    for e in entries:
        e.write_bytes(b"damaged")
    assert page("c.html") == (["yourdfpy", "trimesh"], first)


def test_bare_state_array_page(tabletop, plan, tmp_path):
    from tmpc.runtime.viewer import write_html
    states = [{k: v for k, v in s.items() if k != "mode"} for s in plan["states"]]
    write_html(tabletop, states, tmp_path / "a.html")
    data = embedded((tmp_path / "a.html").read_text())
    assert len(data["states"]) == len(states)


def test_unloadable_visual_meshes_fall_back_to_collision_geometry(tabletop, monkeypatch):
    from tmpc.runtime.viewer import scene as viewer_scene
    real = viewer_scene.load_visual
    monkeypatch.setattr(viewer_scene, "load_visual",
                        lambda path, scale: [] if str(path).endswith(".dae") else real(path, scale))
    poser = viewer_scene.Poser(tabletop, 300)
    assert {"panda_link0", "panda_link7", "panda_hand"} <= set(poser.link_nodes)


def test_decimation_keeps_the_shape():
    import trimesh

    from tmpc.runtime.viewer.page import decimate
    m = trimesh.creation.icosphere(subdivisions=5, radius=0.1)        # 20480 faces
    v, f = decimate(np.asarray(m.vertices), np.asarray(m.faces), 600)
    assert 100 < len(f) <= 600
    r = np.linalg.norm(v, axis=1)
    assert np.all(np.abs(r - 0.1) < 0.01)
    assert f.max() < len(v)


# ---- the snapshot -------------------------------------------------------------------------------

def test_png_has_the_requested_size_and_shows_the_scene(tabletop, plan, tmp_path):
    from PIL import Image

    from tmpc.runtime.viewer.page import BACKGROUND, write_png
    out = tmp_path / "s.png"
    write_png(tabletop, plan, out, state_index=3, size=(320, 240))
    im = Image.open(out)
    assert im.format == "PNG" and im.size == (320, 240)
    a = np.asarray(im.convert("RGB")).astype(int)
    bg = np.round(np.asarray(BACKGROUND) * 255)
    drawn = np.abs(a - bg).sum(2) > 30
    assert 0.15 < drawn.mean() < 0.95                 # something, not everything
    assert len(np.unique(a.reshape(-1, 3), axis=0)) > 50
    red = (a[..., 0] > 150) & (a[..., 1] < 90) & (a[..., 2] < 90)
    assert red.sum() > 10                              # the red cube, in the hand


def test_png_state_out_of_range(tabletop, plan, tmp_path):
    from tmpc.lang.diagnostics import InputError
    from tmpc.runtime.viewer import write_png
    with pytest.raises(InputError, match="the plan has states 0 to 9"):
        write_png(tabletop, plan, tmp_path / "x.png", state_index=10)
    assert not list(tmp_path.iterdir())


# ---- the command --------------------------------------------------------------------------------

def cli(*args):
    """`tmpc view ARGS` in this process (tests.support.tmpc_here: exit code, stdout, stderr)."""
    return tmpc_here("view", *args)


def test_cli(tmp_path):
    plan = PLANS / "tabletop.json"
    r = cli(TABLETOP, plan, "--html", tmp_path / "p.html", "--png", tmp_path / "p.png",
            "--state", "1")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "p.html").stat().st_size > 10_000
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.html", "p.png"]
    r = cli(TABLETOP, plan)
    assert r.returncode == 2 and "--html" in r.stderr
    r = cli(TABLETOP, plan, "--png", tmp_path / "q.png", "--state", "42")
    assert r.returncode == 1 and "E814" in r.stderr and "Traceback" not in r.stderr
    r = cli(TABLETOP, plan, "--html", tmp_path / "missing" / "p.html")
    assert r.returncode == 1 and "E815" in r.stderr
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2")
    r = cli(TABLETOP, bad, "--html", tmp_path / "b.html")
    assert r.returncode == 1 and "E800" in r.stderr and not (tmp_path / "b.html").exists()


def test_the_png_frames_the_whole_scene(tmp_path):
    """Clutter's first state showed the robot alone (the tables were more than a metre away):
    the default view shows every object; the four tables are brown."""
    from PIL import Image

    from tmpc.compiler.artifact import open_world
    from tmpc.runtime.viewer import write_png
    world = open_world(CLUTTER, with_program=False)
    out = tmp_path / "c.png"
    write_png(world, json.loads((PLANS / "clutter.json").read_text()), out, state_index=0,
              size=(400, 300))
    a = np.asarray(Image.open(out).convert("RGB")).astype(int)
    brown = (a[..., 0] > 90) & (a[..., 0] < 160) & (a[..., 1] > 50) & (a[..., 1] < 110) & \
        (a[..., 2] < 80)
    assert brown.mean() > 0.05, brown.mean()


def test_each_movable_object_has_its_own_colour():
    """Objects told apart (issue S): a colour word in a name keeps its colour, every other
    movable object takes its own palette colour."""
    from tmpc.lang.world import load_scene
    from tmpc.runtime.viewer.scene import object_colors
    scene = load_scene(EXAMPLES / "tower" / "scene.json")
    colors = object_colors(scene)
    cubes = [colors[n] for n in ("a", "b", "c")]
    assert len(set(cubes)) == 3 and colors["bench"] not in cubes
    tabletop = object_colors(load_scene(EXAMPLES / "tabletop" / "scene.json"))
    assert tabletop["red_cube"][0] > 0.8 and tabletop["blue_cube"][2] > 0.8


def test_the_page_labels_every_movable_object(tabletop, plan):
    from tmpc.runtime.viewer.page import page_data
    from tmpc.runtime.viewer.png import as_plan
    data = page_data(tabletop, as_plan(plan), "t")
    assert sorted(lb["name"] for lb in data["labels"]) == ["blue_cube", "red_cube"]
    assert all(data["nodes"][lb["node"]] == lb["name"] for lb in data["labels"])


def test_the_snapshot_frames_what_the_plan_moves(tabletop, plan, tmp_path):
    """At the end both cubes are in the tray: the camera frames them (each shows, with its
    label) rather than the whole scene."""
    from PIL import Image

    from tmpc.runtime.viewer.png import write_png
    out = tmp_path / "end.png"
    write_png(tabletop, plan, out, size=(320, 240))
    a = np.asarray(Image.open(out).convert("RGB")).astype(int)
    red = (a[..., 0] > 150) & (a[..., 1] < 90) & (a[..., 2] < 90)
    blue = (a[..., 2] > 150) & (a[..., 0] < 90) & (a[..., 1] < 120)
    assert red.sum() > 15 and blue.sum() > 15, (red.sum(), blue.sum())
