"""The tetrahedral-mesh ray caster against a brute-force reference on meshes whose
region and field are known in closed form (grids of Kuhn tetrahedra), including
non-convex meshes, several components, a cavity, degenerate cells and an eye inside."""

from __future__ import annotations

import numpy as np
import pytest
from naive import render_field_reference

from volpack.errors import VolpackError
from volpack.render.camera import Camera
from volpack.render.tetra import render_mesh
from volpack.render.transfer import TransferFunction

TF = TransferFunction(
    points=((0.0, 1, 0.5, 0.2, 0.02), (10.0, 0.2, 0.9, 0.5, 0.12), (27.0, 0.9, 0.9, 0.9, 0.05))
)


def kuhn_grid(n, offset=(0.0, 0.0, 0.0), keep=None):
    """(x, y, z) points of an n^3 lattice and its cubes split into 6 tetrahedra along the
    main diagonal (conforming across cubes); ``keep(i, j, k)`` drops cubes."""
    k, j, i = np.meshgrid(*(np.arange(n),) * 3, indexing="ij")
    pts = np.stack([i.ravel(), j.ravel(), k.ravel()], 1).astype(float) + offset
    tets = []
    for a in range(n - 1):
        for b in range(n - 1):
            for c in range(n - 1):
                if keep is not None and not keep(c, b, a):
                    continue
                v = [
                    ((a + dz) * n + b + dy) * n + c + dx
                    for dz in (0, 1)
                    for dy in (0, 1)
                    for dx in (0, 1)
                ]
                for p, q in [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]:
                    tets.append([v[0], v[p], v[p | q], v[7]])
    return pts, np.array(tets, np.int64)


def linear(p_zyx):
    return 0.9 * p_zyx[:, 0] + 0.5 * p_zyx[:, 1] + 0.3 * p_zyx[:, 2]


def reference(cam, pts, inside, unit, vr=(0.0, 27.0), steps=3000):
    p = pts[:, ::-1]
    lo_b, hi_b = p.min(0), p.max(0)
    centre, radius = 0.5 * (lo_b + hi_b), 0.5 * np.linalg.norm(hi_b - lo_b)
    o, d = cam.world_rays(centre, radius)
    t_max = float(np.linalg.norm(o[0, 0] - centre) + 2 * radius)
    return render_field_reference(o, d, inside, linear, TF.table(*vr, 256), *vr, unit, t_max, steps)


def test_convex_grid_matches_the_brute_force_reference():
    pts, tets = kuhn_grid(10)
    sc = linear(pts[:, ::-1])
    cam = Camera(size=(20, 20), azimuth=30, elevation=20)
    img = render_mesh(pts, tets, sc, tf=TF, camera=cam, unit=1.0, value_range=(0, 27))
    inside = lambda q: np.all((q >= 0) & (q <= 9), axis=1)  # noqa: E731
    ref = reference(cam, pts, inside, 1.0)
    assert ref[..., 3].max() > 0.5
    np.testing.assert_allclose(img, ref, atol=4e-3)


@pytest.mark.parametrize("case", ["two components", "cavity", "L shape"])
def test_non_convex_meshes_match_the_reference(case):
    if case == "two components":
        p1, t1 = kuhn_grid(5)
        p2, t2 = kuhn_grid(5, offset=(6.0, 1.0, 2.0))
        pts, tets = np.concatenate([p1, p2]), np.concatenate([t1, t2 + len(p1)])

        def inside(q):
            z, y, x = q[:, 0], q[:, 1], q[:, 2]
            a = (x >= 0) & (x <= 4) & (y >= 0) & (y <= 4) & (z >= 0) & (z <= 4)
            b = (x >= 6) & (x <= 10) & (y >= 1) & (y <= 5) & (z >= 2) & (z <= 6)
            return a | b
    elif case == "cavity":
        pts, tets = kuhn_grid(
            8, keep=lambda i, j, k: not (2 <= i <= 4 and 2 <= j <= 4 and 2 <= k <= 4)
        )

        def inside(q):
            box = np.all((q >= 0) & (q <= 7), axis=1)
            hole = np.all((q > 2) & (q < 5), axis=1)
            return box & ~hole
    else:
        pts, tets = kuhn_grid(8, keep=lambda i, j, k: i < 3 or k < 3)

        def inside(q):
            z, x = q[:, 0], q[:, 2]
            return np.all((q >= 0) & (q <= 7), axis=1) & ((x <= 3) | (z <= 3))

    sc = linear(pts[:, ::-1])
    cam = Camera(size=(18, 18), azimuth=50, elevation=25)
    img = render_mesh(pts, tets, sc, tf=TF, camera=cam, unit=0.5, value_range=(0, 27))
    ref = reference(cam, pts, inside, 0.5)
    assert ref[..., 3].max() > 0.3
    np.testing.assert_allclose(img, ref, atol=6e-3)


def test_eye_inside_the_mesh_and_threads_and_degenerate_cells():
    pts, tets = kuhn_grid(6)
    sc = linear(pts[:, ::-1])
    # a zero-volume cell glued on (its four points on one face plane) changes nothing
    flat = np.array([[0.2, 0.3, 0.0], [1.5, 0.1, 0.0], [0.4, 1.7, 0.0], [1.1, 1.2, 0.0]])
    pts2 = np.concatenate([pts, flat])
    tets2 = np.concatenate([tets, [np.arange(len(pts), len(pts) + 4)]])
    sc2 = np.concatenate([sc, linear(flat[:, ::-1])])
    cam = Camera(size=(16, 12), azimuth=10, elevation=5, projection="perspective", distance=0.5)
    one = render_mesh(pts2, tets2, sc2, tf=TF, camera=cam, unit=0.3, value_range=(0, 27), workers=1)
    assert np.all(np.isfinite(one)) and one[..., 3].min() > 0  # every ray starts inside
    for w in (2, 3):
        assert np.array_equal(one, render_mesh(pts2, tets2, sc2, tf=TF, camera=cam, unit=0.3,
                                               value_range=(0, 27), workers=w))  # fmt: skip
    plain = render_mesh(pts, tets, sc, tf=TF, camera=cam, unit=0.3, value_range=(0, 27), workers=1)
    np.testing.assert_allclose(one, plain, atol=1e-6)


def test_constant_field_gives_the_chord_length():
    # one tetrahedron, constant value: alpha = 1 - (1 - a) ** (chord / unit)
    pts = np.array([[0.0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]])
    tf = TransferFunction(points=((0.0, 1, 1, 1, 0.1), (1.0, 1, 1, 1, 0.1)))
    cam = Camera(size=(9, 9), azimuth=0, elevation=0)
    img = render_mesh(pts, np.array([[0, 1, 2, 3]]), np.zeros(4), tf=tf, camera=cam, unit=1.0,
                      shading="phong")  # fmt: skip
    inside = lambda q: (q >= 0).all(axis=1) & (q.sum(axis=1) <= 4)  # noqa: E731
    p = pts[:, ::-1]
    centre, radius = 0.5 * (p.min(0) + p.max(0)), 0.5 * np.linalg.norm(p.max(0) - p.min(0))
    o, d = cam.world_rays(centre, radius)
    ts = np.linspace(0, 40, 40001)
    for r, c in [(4, 4), (5, 3), (6, 2)]:
        chord = np.count_nonzero(inside(o[r, c] + ts[:, None] * d[r, c])) * (ts[1] - ts[0])
        assert img[r, c, 3] == pytest.approx(1 - 0.9**chord, abs=2e-3)


def test_bad_input_and_empty_mesh():
    pts, tets = kuhn_grid(3)
    sc = linear(pts[:, ::-1])
    with pytest.raises(VolpackError, match="indices"):
        render_mesh(pts, tets + 100, sc, tf=TF)
    with pytest.raises(VolpackError, match="one scalar per point"):
        render_mesh(pts, tets, sc[:-1], tf=TF)
    bad = sc.copy()
    bad[0] = np.nan
    with pytest.raises(VolpackError, match="finite"):
        render_mesh(pts, tets, bad, tf=TF)
    img = render_mesh(pts, tets[:0], sc, tf=TF, camera=Camera(size=(4, 4)))
    assert not img.any()


def test_non_manifold_face_and_vertex_render_without_error():
    # three cells on one face (non-manifold), and a cell touching the rest at a vertex only
    pts = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, 2], [0.5, 0.5, -2],
                    [1.5, 1.5, 1.0], [3, 3, 3], [4, 3, 3], [3, 4, 3]], float)  # fmt: skip
    tets = np.array([[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5], [3, 6, 7, 8]])
    img = render_mesh(pts, tets, pts[:, 2], tf=TF, camera=Camera(size=(24, 24)), unit=0.05,
                      value_range=(-2, 3), shading="phong")  # fmt: skip
    assert np.all(np.isfinite(img)) and img[..., 3].max() > 0.1
    assert np.all(
        img[..., :3] <= img[..., 3:] * 1.6 + 1e-6
    )  # colour bounded by opacity (+ specular)


def test_cli_renders_a_mesh_file_and_its_vpk(tmp_path):
    import json

    import meshio
    from click.testing import CliRunner
    from PIL import Image

    from volpack.cli import main

    pts, tets = kuhn_grid(5)
    temp = linear(pts[:, ::-1])
    src = tmp_path / "m.vtu"
    meshio.write(src, meshio.Mesh(pts, [("tetra", tets)], point_data={"temperature": temp},
                                  cell_data={"mat": [np.arange(len(tets)) % 3]}))  # fmt: skip
    run = CliRunner().invoke
    r = run(main, ["compress", str(src), str(tmp_path / "m.vpk")])
    assert r.exit_code == 0, r.output
    for name, extra in [("a.png", []), ("b.png", ["--field", "mat", "--shading", "none"])]:
        r = run(main, ["render", str(tmp_path / "m.vpk"), str(tmp_path / name), "--size", "40x30",
                       "--json", *extra])  # fmt: skip
        assert r.exit_code == 0, r.output
        rep = json.loads(r.stdout)
        assert rep["mesh"]["tets"] == len(tets)
        img = np.asarray(Image.open(tmp_path / name))
        assert img.shape == (30, 40, 3) and img.max() > 40
    # the file itself renders the same picture as its stream
    r = run(main, ["render", str(src), str(tmp_path / "c.png"), "--size", "40x30"])
    assert r.exit_code == 0, r.output
    a = np.asarray(Image.open(tmp_path / "a.png")).astype(int)
    c = np.asarray(Image.open(tmp_path / "c.png")).astype(int)
    assert np.abs(a - c).max() <= 3  # geometry quantised to 16 bits in the stream
    r = run(main, ["render", str(src), str(tmp_path / "d.png"), "--field", "pressure"])
    assert r.exit_code != 0 and "pressure" in r.output


def _inside_tets(pts_zyx, tets):
    """Point-in-any-tetrahedron test by barycentric coordinates (the reference's region)."""

    def inside(q):
        hit = np.zeros(len(q), bool)
        for t in tets:
            a, b, c, d = pts_zyx[t]
            m = np.stack([b - a, c - a, d - a], 1)
            lam = np.linalg.solve(m, (q - a).T).T
            hit |= (lam >= 0).all(1) & (lam.sum(1) <= 1)
        return hit

    return inside


@pytest.mark.slow
def test_a_visibility_cycle_of_three_rods():
    # three thin rods around a triangle, each passing above the next: seen from above,
    # no back-to-front order of the cells exists; the ray walk needs none
    tri = np.array([[0.0, 0.0], [10.0, 0.0], [5.0, 8.66]])
    pts, tets = [], []
    for k in range(3):
        p, q = tri[k], tri[(k + 1) % 3]
        d = (q - p) / np.linalg.norm(q - p)
        n = np.array([-d[1], d[0]])
        s, e = p - 1.5 * d, q + 1.5 * d
        base = [[*(s + 0.6 * n), 1.0], [*(s - 0.6 * n), 1.0], [*s, 1.6]]
        pts += base + [[*e, -1.0]]
        tets.append([4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3])
    pts, tets = np.array(pts), np.array(tets)
    field = pts[:, 0] * 0.3 + pts[:, 1] * 0.2 + pts[:, 2] * 3 + 5  # in 2..12
    cam = Camera(size=(24, 24), azimuth=0, elevation=90)
    img = render_mesh(pts, tets, field, tf=TF, camera=cam, unit=0.2, value_range=(0, 27))
    p = pts[:, ::-1]
    inside = _inside_tets(p, tets)
    lo_b, hi_b = p.min(0), p.max(0)
    o, d = cam.world_rays(0.5 * (lo_b + hi_b), 0.5 * np.linalg.norm(hi_b - lo_b))
    tmax = float(np.linalg.norm(o[0, 0] - 0.5 * (lo_b + hi_b)) + np.linalg.norm(hi_b - lo_b))

    def fz(q):  # the field of the rods, linear in (x, y, z): the same formula on (z, y, x)
        return q[:, 2] * 0.3 + q[:, 1] * 0.2 + q[:, 0] * 3 + 5

    ref = render_field_reference(o, d, inside, fz, TF.table(0, 27, 256), 0, 27, 0.2, tmax, 4000)
    assert ref[..., 3].max() > 0.2
    np.testing.assert_allclose(img, ref, atol=6e-3)
