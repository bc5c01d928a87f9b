#!/usr/bin/env python3
"""Write a seam-cut copy of a triangulated OBJ: one vertex per distinct (position, UV) pair,
faces `f a/a b/b c/c`, no normals or materials.

The authors' ExtractMeshesFromUV.m keeps one UV per position (UV(obj.f.v,:) = obj.vt(obj.f.vt,:),
the last assignment winning), so a mesh with UV seams must be cut along them before their code
sees it; reparam treats the same seams as boundaries (`bpm qc` reports them as "UV seam"
edges), so both codes then measure the same charts. Vertices keep the order of their first
appearance in the faces; unreferenced positions and UVs are dropped.

usage: seam_cut.py in.obj out.obj
"""
import sys


def main(src, dst):
    positions, uvs, faces = [], [], []
    with open(src) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                positions.append(parts[1:4])
            elif parts[0] == "vt":
                uvs.append(parts[1:3])
            elif parts[0] == "f":
                corners = [c.split("/") for c in parts[1:]]
                if len(corners) != 3 or any(len(c) < 2 or not c[1] for c in corners):
                    sys.exit(f"{src}: only triangles with texture coordinates are supported")
                faces.append([(int(c[0]), int(c[1])) for c in corners])

    def absolute(i, n):
        return i - 1 if i > 0 else n + i

    index, out_v, out_vt, out_f = {}, [], [], []
    for face in faces:
        row = []
        for p, t in face:
            key = (absolute(p, len(positions)), absolute(t, len(uvs)))
            if key not in index:
                index[key] = len(out_v) + 1
                out_v.append(positions[key[0]])
                out_vt.append(uvs[key[1]])
            row.append(index[key])
        out_f.append(row)
    with open(dst, "w") as f:
        f.write(f"# seam-cut copy of {src}: {len(out_v)} vertices, {len(out_f)} faces\n")
        for p in out_v:
            f.write("v " + " ".join(p) + "\n")
        for t in out_vt:
            f.write("vt " + " ".join(t) + "\n")
        for a, b, c in out_f:
            f.write(f"f {a}/{a} {b}/{b} {c}/{c}\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
