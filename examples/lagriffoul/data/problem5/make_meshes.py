"""Write the kitchen's meshes (kitchen_meshes/*.obj): boxes and cylinders, each object's origin
at the middle of its bottom face, as the suite's meshes have it. Run once; the OBJ files are
committed as data (`python examples/lagriffoul/data/problem5/make_meshes.py`)."""

from __future__ import annotations

import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "kitchen_meshes"

Box = tuple[float, float, float, float, float, float]   # xmin, xmax, ymin, ymax, zmin, zmax


def box_faces(b: Box, first: int) -> tuple[list[tuple[float, float, float]], list[tuple[int, ...]]]:
    x0, x1, y0, y1, z0, z1 = b
    v = [(x, y, z) for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)]
    # outward-facing quads (1-based indices into v), split into triangles
    quads = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    faces = []
    for a, b_, c, d in quads:
        faces += [(first + a, first + b_, first + c), (first + a, first + c, first + d)]
    return v, faces


def cylinder(radius: float, height: float, sides: int = 24):
    v = [(0.0, 0.0, 0.0), (0.0, 0.0, height)]
    for z in (0.0, height):
        v += [(radius * math.cos(2 * math.pi * k / sides), radius * math.sin(2 * math.pi * k / sides), z)
              for k in range(sides)]
    f = []
    for k in range(sides):
        a, b = 3 + k, 3 + (k + 1) % sides
        f.append((1, b, a))                                   # bottom
        f.append((2, sides + a, sides + b))                   # top
        f += [(a, b, sides + b), (a, sides + b, sides + a)]   # side
    return v, f


def boxes(parts: list[Box]):
    v, f = [], []
    for b in parts:
        bv, bf = box_faces(b, len(v))
        v += bv
        f += bf
    return v, f


def write(name: str, mesh) -> None:
    v, f = mesh
    lines = [f"# {name}: written by make_meshes.py (metres; origin at the bottom centre)"]
    lines += [f"v {x:.4f} {y:.4f} {z:.4f}" for x, y, z in v]
    lines += ["f " + " ".join(map(str, face)) for face in f]
    (OUT / f"{name}.obj").write_text("\n".join(lines) + "\n")


#: furniture: (depth x, width y, top height z); the shelf's walls and roof are 2 cm thick
SHELF = (0.30, 0.50, 0.80, 0.33)          # depth, width, board top, inner height
TABLE = (0.40, 0.40, 0.70)
DISHWASHER = (0.28, 0.28, 0.78)
STOVE = (0.24, 0.24, 0.78)


def main() -> None:
    OUT.mkdir(exist_ok=True)
    # the shelf in convex parts (collision checkers take a mesh's convex hull), all in the
    # shelf's frame: the cabinet whose top is the board, the back wall, the sides, the roof
    d, w, top, inner = SHELF
    t = 0.02
    write("shelf", boxes([(-d / 2, d / 2, -w / 2, w / 2, 0.0, top)]))
    write("shelf_back", boxes([(d / 2 - t, d / 2, -w / 2, w / 2, top, top + inner)]))
    write("shelf_left", boxes([(-d / 2, d / 2, w / 2 - t, w / 2, top, top + inner)]))
    write("shelf_right", boxes([(-d / 2, d / 2, -w / 2, -w / 2 + t, top, top + inner)]))
    write("shelf_roof", boxes([(-d / 2, d / 2, -w / 2, w / 2, top + inner, top + inner + t)]))
    d, w, top = TABLE
    leg = 0.04
    write("dining_table", boxes([
        (-d / 2, d / 2, -w / 2, w / 2, top - 0.03, top),                   # the top
        *[(sx * d / 2 - (leg if sx > 0 else 0), sx * d / 2 + (0 if sx > 0 else leg),
           sy * w / 2 - (leg if sy > 0 else 0), sy * w / 2 + (0 if sy > 0 else leg),
           0.0, top - 0.03) for sx in (-1, 1) for sy in (-1, 1)],
    ]))
    d, w, top = DISHWASHER
    write("dishwasher", boxes([(-d / 2, d / 2, -w / 2, w / 2, 0.0, top)]))
    d, w, top = STOVE
    write("stove", boxes([(-d / 2, d / 2, -w / 2, w / 2, 0.0, top - 0.01),
                          (-0.08, 0.08, -0.08, 0.08, top - 0.01, top)]))      # a hob plate
    write("glass", cylinder(0.035, 0.14))
    write("cabbage", cylinder(0.035, 0.12))                # a PR2 opens to about 9 cm
    write("radish", cylinder(0.025, 0.09))                  # with its leaves
    # the places on the table and the radishes' spots on the shelf: 2 mm discs (as the
    # Non-Monotonic problem's targets), resting on their furniture
    write("glass_place", cylinder(0.045, 0.002))
    write("cabbage_place", cylinder(0.06, 0.002))
    write("radish_spot", cylinder(0.03, 0.002))


if __name__ == "__main__":
    main()
