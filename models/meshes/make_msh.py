#!/usr/bin/env python3
"""Write the Gmsh 4.1 ASCII meshes the models and tests import (no gmsh needed).

    python3 models/meshes/make_msh.py

- plate_hole.msh: a quarter of a square plate (half width W = 0.1 m) with a central hole of
  radius a = 0.02 m, quad4, mapped from the hole to the outer edges in two blocks split
  at 45 degrees, graded towards the hole. Physical groups: "left" (x = 0), "bottom"
  (y = 0), "right" (x = W), "hole", "plate" (the surface).
- bracket_hex.msh / bracket_tet.msh: an L-shaped bracket of hexahedra (and the same split
  into 6 tetrahedra per hex), 1 cm cells. Physical groups: "base" (the face z = 0),
  "arm" (the face x = 0.08 m at the arm's end), "solid" (the volume).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write(path, names, nodes, groups):
    """names: [(dim, tag, name)]; nodes: [(x, y, z)] (1-based tags in order);
    groups: [(dim, entity_tag, physical_tag, gmsh_type, [[node tags]])]."""
    with open(path, "w") as f:
        f.write("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n")
        f.write("$PhysicalNames\n%d\n" % len(names))
        for dim, tag, name in names:
            f.write('%d %d "%s"\n' % (dim, tag, name))
        f.write("$EndPhysicalNames\n")
        counts = [0, 0, 0, 0]
        ents = {1: [], 2: [], 3: []}
        for dim, etag, ptag, _, _ in groups:
            counts[dim] += 1
            ents[dim].append((etag, ptag))
        f.write("$Entities\n0 %d %d %d\n" % (counts[1], counts[2], counts[3]))
        for dim in (1, 2, 3):
            for etag, ptag in ents[dim]:
                f.write("%d 0 0 0 1 1 1 1 %d 0\n" % (etag, ptag))
        f.write("$EndEntities\n")
        n = len(nodes)
        # all nodes in one block on the highest-dimensional entity
        top = max(groups, key=lambda g: g[0])
        f.write("$Nodes\n1 %d 1 %d\n%d %d 0 %d\n" % (n, n, top[0], top[1], n))
        for i in range(n):
            f.write("%d\n" % (i + 1))
        for x, y, z in nodes:
            f.write("%.12g %.12g %.12g\n" % (x, y, z))
        f.write("$EndNodes\n")
        total = sum(len(g[4]) for g in groups)
        f.write("$Elements\n%d %d 1 %d\n" % (len(groups), total, total))
        tag = 1
        for dim, etag, _, gtype, els in groups:
            f.write("%d %d %d %d\n" % (dim, etag, gtype, len(els)))
            for e in els:
                f.write("%d %s\n" % (tag, " ".join(str(v) for v in e)))
                tag += 1
        f.write("$EndElements\n")


def plate_hole(path, w=0.1, a=0.02, nr=16, nt=12):
    nodes = []
    idx = {}
    for j in range(2 * nt + 1):
        th = (math.pi / 2) * j / (2 * nt)
        if j <= nt:
            outer = (w, w * math.tan(th))
        else:
            outer = (w / math.tan(th) if j < 2 * nt else 0.0, w)
        inner = (a * math.cos(th), a * math.sin(th))
        for i in range(nr + 1):
            s = (i / nr) ** 1.6  # graded towards the hole
            x = inner[0] + s * (outer[0] - inner[0])
            y = inner[1] + s * (outer[1] - inner[1])
            if j == 2 * nt:
                x = 0.0
            if j == 0:
                y = 0.0
            nodes.append((x, y, 0.0))
            idx[(i, j)] = len(nodes)
    quads = []
    for j in range(2 * nt):
        for i in range(nr):
            quads.append([idx[(i, j)], idx[(i + 1, j)], idx[(i + 1, j + 1)], idx[(i, j + 1)]])
    line = lambda pts: [[pts[k], pts[k + 1]] for k in range(len(pts) - 1)]
    left = line([idx[(i, 2 * nt)] for i in range(nr + 1)])
    bottom = line([idx[(i, 0)] for i in range(nr + 1)])
    right = line([idx[(nr, j)] for j in range(nt + 1)])
    hole = line([idx[(0, j)] for j in range(2 * nt + 1)])
    names = [(1, 1, "left"), (1, 2, "bottom"), (1, 3, "right"), (1, 4, "hole"), (2, 5, "plate")]
    groups = [
        (1, 1, 1, 1, left),
        (1, 2, 2, 1, bottom),
        (1, 3, 3, 1, right),
        (1, 4, 4, 1, hole),
        (2, 1, 5, 3, quads),
    ]
    write(path, names, nodes, groups)


def bracket(path_hex, path_tet, h=0.01):
    # L shape: a base 8 x 2 x 1 cells along x on z in [0, 1 cm] ... built as a set of cells
    cells = set()
    for i in range(8):
        for j in range(2):
            cells.add((i, j, 0))
    for k in range(1, 6):
        for j in range(2):
            cells.add((0, j, k))
    # arm along x at the top
    for i in range(1, 8):
        for j in range(2):
            cells.add((i, j, 5))
    idx = {}
    nodes = []

    def node(i, j, k):
        if (i, j, k) not in idx:
            nodes.append((i * h, j * h, k * h))
            idx[(i, j, k)] = len(nodes)
        return idx[(i, j, k)]

    hexes = []
    for (i, j, k) in sorted(cells, key=lambda c: (c[2], c[1], c[0])):
        hexes.append([
            node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
            node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1),
        ])
    base = [[idx[(i, j, 0)], idx[(i + 1, j, 0)], idx[(i + 1, j + 1, 0)], idx[(i, j + 1, 0)]]
            for i in range(8) for j in range(2)]
    arm = [[idx[(8, j, k)], idx[(8, j + 1, k)], idx[(8, j + 1, k + 1)], idx[(8, j, k + 1)]]
           for j in range(2) for k in (5,)]
    names = [(2, 1, "base"), (2, 2, "arm"), (3, 3, "solid")]
    write(path_hex, names, nodes,
          [(2, 1, 1, 3, base), (2, 2, 2, 3, arm), (3, 1, 3, 5, hexes)])
    # 6 tetrahedra around the 0-6 diagonal (positively oriented)
    tets = []
    for e in hexes:
        n = e
        for a, b, c, d in ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)):
            tets.append([n[a], n[b], n[c], n[d]])
    tri = lambda q: [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    write(path_tet, names, nodes,
          [(2, 1, 1, 2, [t for q in base for t in tri(q)]),
           (2, 2, 2, 2, [t for q in arm for t in tri(q)]),
           (3, 1, 3, 4, tets)])


if __name__ == "__main__":
    plate_hole(os.path.join(HERE, "plate_hole.msh"))
    bracket(os.path.join(HERE, "bracket_hex.msh"), os.path.join(HERE, "bracket_tet.msh"))
