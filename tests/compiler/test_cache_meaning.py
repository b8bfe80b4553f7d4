"""The run cache is keyed by what the program and scene mean (issue S): a comment or layout edit
of the domain, problem or scene reuses the compiled artifact; an edit of meaning does not."""

from __future__ import annotations

import json
import shutil

from tests.support import EXAMPLES
from tmpc.compiler.cache import source_key
from tmpc.compiler.kernels import Options
from tmpc.lang.inputs import load_world


def _copy(tmp_path):
    for f in (EXAMPLES / "tower").iterdir():
        shutil.copy(f, tmp_path / f.name)
    return tmp_path / "tower.toml"


def _key(cfg):
    return source_key(load_world(cfg), Options())


def test_comments_and_layout_keep_the_key(tmp_path):
    cfg = _copy(tmp_path)
    before = _key(cfg)
    dom = tmp_path / "domain.pddl"
    dom.write_text("; a new comment\n" + dom.read_text().replace("(:action pick",
                                                                 "\n\n   (:action   pick"))
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(json.loads(scene.read_text()), indent=4))
    assert _key(cfg) == before


def test_an_edit_of_meaning_changes_the_key(tmp_path):
    cfg = _copy(tmp_path)
    before = _key(cfg)
    dom = tmp_path / "domain.pddl"
    dom.write_text(dom.read_text().replace("(near ?g ?c 0.02)", "(near ?g ?c 0.03)"))
    assert _key(cfg) != before
    dom.write_text(dom.read_text().replace("(near ?g ?c 0.03)", "(near ?g ?c 0.02)"))
    assert _key(cfg) == before
    scene = tmp_path / "scene.json"
    data = json.loads(scene.read_text())
    data["objects"][1]["pose"]["translation"][0] += 0.01
    scene.write_text(json.dumps(data))
    assert _key(cfg) != before
