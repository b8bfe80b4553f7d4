"""Retreat chains (runtime/planners/retreat.py): straight hand motions, checked by forward
kinematics rather than by the Jacobian that made them."""

from __future__ import annotations

import numpy as np

from tmpc.runtime.planners.retreat import (
    DIRECTIONS,
    SIDEWAYS,
    cartesian_steps,
    hand_frames,
    retreat_chains,
)


def test_a_step_moves_the_hand_straight_and_keeps_its_orientation(clutter_problem_1):
    p = clutter_problem_1
    hands = hand_frames(p)
    assert hands, "the clutter domain grasps with a gripper frame"
    rng = np.random.default_rng(0)
    Q = p.uniform(rng, 6)
    for d in range(len(DIRECTIONS) + len(SIDEWAYS)):
        Q1 = cartesian_steps(p, Q, np.full(len(Q), hands[0]), np.full(len(Q), d), 0.01)
        for q, q1 in zip(Q, Q1):
            if not np.allclose(np.clip(q1, p.lower, p.upper), q1) or \
                    np.isclose(q1, p.lower).any() or np.isclose(q1, p.upper).any():
                continue                                     # at a joint limit: not straight
            f0, f1 = p.frames_of(np.stack([q, q1]))
            R0, R1 = f0.R[hands[0]], f1.R[hands[0]]
            moved = f1.p[hands[0]] - f0.p[hands[0]]
            up, back = np.array([0.0, 0.0, 1.0]), -R0[:, 0]
            want = (up, back, (up + back) / np.sqrt(2), R0[:, 1], -R0[:, 1], R0[:, 2],
                    -R0[:, 2])[d] * 0.01
            assert np.linalg.norm(moved - want) < 1.5e-3, (d, moved, want)
            # the orientation changes by at most a few milliradians
            assert np.linalg.norm(R1 - R0) < 0.02


def test_chains_are_free_and_stop_at_a_collision(clutter_problem_1):
    p = clutter_problem_1
    hands = hand_frames(p)
    chains = retreat_chains(p, [(p.initial, p.q0)], hands, steps=6, step=0.02)[0]
    assert len(chains) == len(hands) * len(DIRECTIONS) and any(chains)
    for chain in chains:
        prev = p.q0
        for q in chain:
            assert p.motions_valid(p.initial, prev[None], q[None], 0.05, ends=True)[0]
            prev = q


def test_chains_of_each_items_own_hands_and_sideways(clutter_problem_1):
    """``hands`` per item: each item's chains are its own hands' (all directions of each,
    sideways ones after the three with ``sideways``), and a sideways chain moves its hand
    along the hand's y or z axis."""
    p = clutter_problem_1
    hands = hand_frames(p)
    items = [(p.initial, p.q0), (p.initial, p.q0)]
    chains = retreat_chains(p, items, [hands[:1], []], steps=3, step=0.02, sideways=True)
    assert len(chains[0]) == len(DIRECTIONS) + len(SIDEWAYS) and chains[1] == []
    plain = retreat_chains(p, items[:1], hands[:1], steps=3, step=0.02)[0]
    assert [len(c) for c in plain] == [len(c) for c in chains[0][:len(DIRECTIONS)]]
    moved = [c for c in chains[0][len(DIRECTIONS):] if c]
    assert moved, "the clutter robot's hand slides at its start"
    f0 = p.frames_of(p.q0[None])[0]
    R0, o0 = f0.R[hands[0]], f0.p[hands[0]]
    for k, c in enumerate(chains[0][len(DIRECTIONS):]):
        if c:
            d = p.frames_of(c[0][None])[0].p[hands[0]] - o0
            axis = (R0[:, 1], -R0[:, 1], R0[:, 2], -R0[:, 2])[k]
            assert np.dot(d, axis) > 0.015 and np.linalg.norm(np.cross(d, axis)) < 3e-3


def test_an_actions_hands_are_the_frames_it_grasps_or_releases_with(blocks_d):
    p = blocks_d
    frame = {p.model.frames[f]: f for f in hand_frames(p)}
    assert set(frame) == {"l_gripper_tool_frame", "r_gripper_tool_frame"}
    grasp = p.ground.find_action("pickup", "a", "table", "l_gripper_tool_frame")
    release = p.ground.find_action("putdown", "c", "table", "r_gripper_tool_frame")
    assert hand_frames(p, grasp) == [frame["l_gripper_tool_frame"]]
    assert hand_frames(p, release) == [frame["r_gripper_tool_frame"]]
