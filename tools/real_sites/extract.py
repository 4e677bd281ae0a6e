#!/usr/bin/env python3
"""Real-geometry scenario suite for has: six sites cut from Sionna RT's OpenStreetMap city scenes.

Made with sionna-rt 2.2.0 (its bundled scenes `munich` and `san_francisco`), numpy, scipy,
trimesh, matplotlib (contourpy). Run from the repository root:

    /work/venv/bin/python tools/real_sites/extract.py [--sites NAME,NAME] [--scenes DIR]

For every site of SITES below it cuts a square around a target building group from the city scene
(whole buildings: every building whose footprint meets the square; no mesh is clipped except the
San Francisco terrain, which is cut to the square) and writes

    fixtures/real/<site>/scene.xml        Mitsuba 3 / Sionna RT XML (one <shape> per wall / roof mesh)
    fixtures/real/<site>/meshes/*.ply     binary little-endian PLY (float x, y, z; uchar/int faces)
    fixtures/real/<site>.toml             the has scenario (radar/imaging values of
                                          fixtures/suite/factory_site.toml)

Object ids (has object names = shape ids without `mesh-`): target buildings `t_<osm name>-wall`,
`t_<osm name>-roof`; neighbours `n_<osm name>-...`; the ground `ground`.

Frames: the site's local frame is the scene frame translated by -origin (origin given in the
TOML header; x, y rounded to metres; z = the terrain height under the target group, 0 in Munich).

Sensors are placed automatically (deterministic): base stations on neighbouring facades (1.5 m in
front, 8-25 m above the ground) or roofs, vehicle tracks on free street ground (>= 1.5 m from every
building), one UAV track above the group; each is chosen for line of sight to the target group,
checked by exact ray-triangle casts against the whole cut scene.
"""
import argparse
import math
import os
import re
import sys

import numpy as np
import trimesh
from scipy import ndimage as ndi
import contourpy

SIONNA_VERSION = "2.2.0"
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
OUT = os.path.join(ROOT, "fixtures", "real")
RES = 0.25  # raster cell, m

# site, city, target buildings (Sionna/OSM building names), note
SITES = [
    ("munich_angerhof", "munich", ["Angerhof"],
     "Angerhof: one polygonal block with an inner courtyard, metal roof"),
    ("munich_justiz_maxturm", "munich", ["Justizgeb_ude_Pacellistra_e", "Maxturm"],
     "Justizgebaeude Pacellistrasse with the Maxturm: the tall site (30 m)"),
    ("munich_singlspieler", "munich", ["Singlspielerhaus", "element_106", "element_130"],
     "Singlspielerhaus group (3 buildings, small courtyard) 4 m from its neighbours"),
    ("sf_bimbos", "san_francisco", ["Bimbo_s_365_Club"],
     "Bimbo's 365 Club: one large irregular footprint on a slope"),
    ("sf_block_044", "san_francisco", ["element_044", "element_045"],
     "two adjacent buildings with a large polygonal footprint"),
    ("sf_element_2172", "san_francisco", ["element_2172"],
     "a single building 3.5 m from its neighbour, on flat ground"),
]

REGION_MARGIN = 15.0  # the area of interest reaches this far past the group (streets included)
CUT_MARGIN = 40.0     # the cut square reaches this far past the region's bounding box
NEIGHBOUR_GAP = 3.0   # the region ends this far from a neighbour's facade (at most)


# ----------------------------------------------------------------------------- scene reading
def read_scene(scene_dir, city):
    xml = open(os.path.join(scene_dir, city, city + ".xml")).read()
    bsdfs = {}
    for m in re.finditer(r'<bsdf type="itu-radio-material" id="([^"]+)">(.*?)</bsdf>', xml, re.S):
        ty = re.search(r'name="type" value="([^"]+)"', m.group(2)).group(1)
        th = re.search(r'name="thickness" value="([^"]+)"', m.group(2))
        bsdfs[m.group(1)] = (ty, th.group(1) if th else None)
    buildings = {}
    ground = None
    for m in re.finditer(r'<shape type="ply" id="([^"]+)"[^>]*>(.*?)</shape>', xml, re.S):
        sid, body = m.group(1), m.group(2)
        fn = re.search(r'name="filename" value="([^"]+)"', body).group(1)
        ref = re.search(r'<ref id="([^"]+)"', body).group(1)
        mesh = trimesh.load(os.path.join(scene_dir, city, fn), process=False)
        V = np.asarray(mesh.vertices, dtype=np.float64)
        F = np.asarray(mesh.faces, dtype=np.int64)
        name = sid[len("mesh-"):]
        if name in ("ground", "Terrain"):
            ground = (ref, V, F)
            continue
        base, part = name.rsplit("-", 1) if "-" in name else (name, "")
        buildings.setdefault(base, []).append((part, ref, V, F))
    return bsdfs, buildings, ground


def part_label(city, part, ref):
    """wall / roof label of a building part (munich: itu_marble walls, itu_metal roofs)."""
    if city == "san_francisco":
        return "roof" if part == "roof" else "wall"
    return {"itu_marble": "wall", "itu_brick": "wall", "itu_metal": "roof", "itu_wood": "roof"}.get(part, "all")


# ----------------------------------------------------------------------------- rasters
class Grid:
    def __init__(self, x0, y0, nx, ny):
        self.x0, self.y0, self.nx, self.ny = x0, y0, nx, ny

    def xy(self, i, j):
        return self.x0 + (i + 0.5) * RES, self.y0 + (j + 0.5) * RES

    def ij(self, x, y):
        return (np.floor((np.asarray(x) - self.x0) / RES).astype(int),
                np.floor((np.asarray(y) - self.y0) / RES).astype(int))


def raster_tris(grid, tris, out_mask=None, out_z=None, zmode="max"):
    """Rasterise triangles (n,3,3) into a mask and/or a height field (max or min of z)."""
    for t in tris:
        mn = np.floor((t[:, :2].min(0) - [grid.x0, grid.y0]) / RES).astype(int)
        mx = np.ceil((t[:, :2].max(0) - [grid.x0, grid.y0]) / RES).astype(int)
        mn = np.maximum(mn, 0)
        mx = np.minimum(mx, [grid.nx - 1, grid.ny - 1])
        if (mx < mn).any():
            continue
        ii = np.arange(mn[0], mx[0] + 1)
        jj = np.arange(mn[1], mx[1] + 1)
        X, Y = np.meshgrid(grid.x0 + (ii + 0.5) * RES, grid.y0 + (jj + 0.5) * RES)
        a, b, c = t
        d = (b[1] - c[1]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[1] - c[1])
        if abs(d) < 1e-4:  # sliver (the terrain has some): nothing to rasterise
            continue
        l1 = ((b[1] - c[1]) * (X - c[0]) + (c[0] - b[0]) * (Y - c[1])) / d
        l2 = ((c[1] - a[1]) * (X - c[0]) + (a[0] - c[0]) * (Y - c[1])) / d
        l3 = 1 - l1 - l2
        m = (l1 >= -1e-6) & (l2 >= -1e-6) & (l3 >= -1e-6)
        if not m.any():
            continue
        sl = (slice(mn[1], mx[1] + 1), slice(mn[0], mx[0] + 1))
        if out_mask is not None:
            out_mask[sl][m] = True
        if out_z is not None:
            z = l1 * a[2] + l2 * b[2] + l3 * c[2]
            sub = out_z[sl]
            if zmode == "max":
                sub[m] = np.fmax(sub[m], z[m])
            else:
                sub[m] = np.fmin(sub[m], z[m])


# ----------------------------------------------------------------------------- ray casts
def segment_blocked(tris, origins, ends, chunk=64):
    """Exact test: is the open segment origin->end hit by any triangle (Moller-Trumbore)?"""
    v0 = tris[:, 0]
    e1 = tris[:, 1] - v0
    e2 = tris[:, 2] - v0
    out = np.zeros(len(origins), bool)
    for s in range(0, len(origins), chunk):
        o = origins[s:s + chunk, None, :]
        d = ends[s:s + chunk, None, :] - o
        p = np.cross(d, e2[None])
        det = np.einsum("ijk,jk->ij", p, e1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = o - v0[None]
        u = np.einsum("ijk,ijk->ij", tv, p) * inv
        q = np.cross(tv, e1[None])
        v = np.einsum("ijk,ijk->ij", d, q) * inv
        t = np.einsum("jk,ijk->ij", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6) & (t < 1 - 1e-6)
        out[s:s + chunk] = hit.any(1)
    return out


# ----------------------------------------------------------------------------- geometry helpers
def rdp(pts, eps):
    if len(pts) < 3:
        return pts
    a, b = pts[0], pts[-1]
    ab = b - a
    n = np.hypot(*ab)
    if n < 1e-9:
        d = np.hypot(*(pts - a).T)
    else:
        d = np.abs(ab[0] * (pts[:, 1] - a[1]) - ab[1] * (pts[:, 0] - a[0])) / n
    k = int(np.argmax(d))
    if d[k] > eps:
        return np.vstack([rdp(pts[:k + 1], eps)[:-1], rdp(pts[k:], eps)])
    return np.vstack([a, b])


def simplify_ring(ring, eps):
    # split the closed ring at its two farthest points so RDP keeps them
    ring = ring[:-1] if np.allclose(ring[0], ring[-1]) else ring
    i = 0
    j = int(np.argmax(np.hypot(*(ring - ring[0]).T)))
    a = rdp(np.vstack([ring[i:j + 1]]), eps)
    b = rdp(np.vstack([ring[j:], ring[:1]]), eps)
    return np.vstack([a[:-1], b[:-1]])


def segments_cross(p1, p2, p3, p4):
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    d1, d2 = orient(p3, p4, p1), orient(p3, p4, p2)
    d3, d4 = orient(p1, p2, p3), orient(p1, p2, p4)
    return (d1 * d2 < 0) and (d3 * d4 < 0)


def is_simple(poly):
    n = len(poly)
    for i in range(n):
        for j in range(i + 1, n):
            if abs(i - j) <= 1 or (i == 0 and j == n - 1):
                continue
            if segments_cross(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]):
                return False
    return True


def points_in_poly(poly, pts):
    from matplotlib.path import Path
    return Path(poly).contains_points(pts)


def write_ply(path, V, F):
    V = np.asarray(V, dtype="<f4")
    F = np.asarray(F, dtype="<i4")
    head = ("ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(V)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    rec = np.empty(len(F), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    rec["n"] = 3
    rec["i"] = F
    with open(path, "wb") as f:
        f.write(head.encode("ascii"))
        f.write(V.tobytes())
        f.write(rec.tobytes())


def compact(V, F):
    used, inv = np.unique(F.ravel(), return_inverse=True)
    return V[used], inv.reshape(F.shape)


# ----------------------------------------------------------------------------- the site
class Site:
    def __init__(self, name, city, targets, note, scene):
        self.name, self.city, self.targets, self.note = name, city, targets, note
        self.bsdfs, self.buildings, self.ground = scene
        missing = [t for t in targets if t not in self.buildings]
        if missing:
            raise SystemExit(f"{name}: unknown buildings {missing}")

    def build(self):
        B = self.buildings
        tv = np.concatenate([p[2] for t in self.targets for p in B[t]])
        c = 0.5 * (tv[:, :2].min(0) + tv[:, :2].max(0))
        half = 0.5 * (tv[:, :2].max(0) - tv[:, :2].min(0)).max() + REGION_MARGIN + CUT_MARGIN
        self.cut_min, self.cut_max = c - half, c + half
        ox, oy = np.round(c)
        # buildings whose footprint meets the square: bbox prefilter, then any footprint cell inside
        grid0 = Grid(self.cut_min[0], self.cut_min[1], int(2 * half / RES) + 1, int(2 * half / RES) + 1)
        keep = []
        for b, parts in B.items():
            V = np.concatenate([p[2] for p in parts])
            if (V[:, :2].max(0) < self.cut_min).any() or (V[:, :2].min(0) > self.cut_max).any():
                continue
            if b in self.targets:
                keep.append(b)
                continue
            m = np.zeros((grid0.ny, grid0.nx), bool)
            for part, ref, V, F in parts:
                raster_tris(grid0, V[F], out_mask=m)
            inside = ((V[:, :2] >= self.cut_min) & (V[:, :2] <= self.cut_max)).all(1).any()
            if m.any() or inside:
                keep.append(b)
        self.keep = sorted(keep, key=lambda b: (b not in self.targets, b))
        # terrain (san_francisco) cut to the square (+5 m), its height under the group = z origin
        self.terrain = None
        oz = 0.0
        if self.city == "san_francisco":
            ref, V, F = self.ground
            cen = V[F].mean(1)[:, :2]
            sel = ((cen >= self.cut_min - 5) & (cen <= self.cut_max + 5)).all(1)
            Vt, Ft = compact(V, F[sel])
            self.terrain = (ref, Vt, Ft)
        self.origin = np.array([ox, oy, 0.0])
        # local copies
        self.parts = []  # (object id, label, ref, V, F, is_target)
        for b in self.keep:
            tgt = b in self.targets
            for part, ref, V, F in B[b]:
                lab = part_label(self.city, part, ref)
                oid = ("t_" if tgt else "n_") + b + ("" if lab == "all" else "-" + lab)
                self.parts.append([oid, lab, ref, V - self.origin, F, tgt])
        if self.terrain is not None:
            # z origin: the lowest terrain under the target group
            ref, Vt, Ft = self.terrain
            self.terrain = (ref, Vt - self.origin, Ft)
            self.grid_setup()
            tz = self.terrain_z[self.tmask]
            oz = float(np.floor(tz.min() * 8) / 8)
            self.origin[2] = oz
            for p in self.parts:
                p[3] = p[3] - [0, 0, oz]
            ref, Vt, Ft = self.terrain
            self.terrain = (ref, Vt - [0, 0, oz], Ft)
            # A building stands on the ground: the city scene extrudes each footprint from one
            # base height, which leaves walls hanging up to 4 m over a sloping street (radar
            # would see under them, and the truth would lack their lowest storey). Each wall's
            # bottom vertices go down (or up) to the terrain under them.
            self.grid_setup()
            for p in self.parts:
                if p[1] in ("wall", "all"):
                    V = p[3].copy()
                    bottom = V[:, 2] < V[:, 2].min() + 0.01
                    V[bottom, 2] = self.ground_at(V[bottom, 0], V[bottom, 1])
                    p[3] = V
        self.grid_setup()

    def grid_setup(self):
        lo = self.cut_min - self.origin[:2]
        hi = self.cut_max - self.origin[:2]
        n = int(np.ceil((hi - lo).max() / RES))
        g = Grid(lo[0], lo[1], n, n)
        self.grid = g
        self.bmask = np.zeros((g.ny, g.nx), bool)    # any building
        self.tmask = np.zeros((g.ny, g.nx), bool)    # target group
        self.top = np.full((g.ny, g.nx), -np.inf)    # roof height
        self.owner = np.zeros((g.ny, g.nx), np.int32)
        for k, (oid, lab, ref, V, F, tgt) in enumerate(self.parts, 1):
            m = np.zeros_like(self.bmask)
            raster_tris(g, V[F], out_mask=m, out_z=self.top)
            self.bmask |= m
            if tgt:
                self.tmask |= m
            self.owner[m & (self.owner == 0)] = k
        self.terrain_z = np.zeros((g.ny, g.nx))
        if self.terrain is not None:
            tz = np.full((g.ny, g.nx), -np.inf)
            ref, Vt, Ft = self.terrain
            raster_tris(g, Vt[Ft], out_z=tz)
            bad = ~np.isfinite(tz)
            if bad.any():
                idx = ndi.distance_transform_edt(bad, return_distances=False, return_indices=True)
                tz = tz[tuple(idx)]
            self.terrain_z = tz
        self.nmask = self.bmask & ~self.tmask
        self.dist_b, self.near_idx = ndi.distance_transform_edt(~self.bmask, sampling=RES, return_indices=True)

    def ground_at(self, x, y):
        i, j = self.grid.ij(x, y)
        i = np.clip(i, 0, self.grid.nx - 1)
        j = np.clip(j, 0, self.grid.ny - 1)
        return self.terrain_z[j, i]

    # ------------------------------------------------------------------ region
    def make_region(self):
        g = self.grid
        cell = RES
        tdil = ndi.distance_transform_edt(~self.tmask, sampling=cell)
        ndist = ndi.distance_transform_edt(~self.nmask, sampling=cell)
        clear = float(ndist[self.tmask].min())
        self.clearance = clear
        gap = min(NEIGHBOUR_GAP, max(clear - 1.0, 1.5))
        R = (tdil <= REGION_MARGIN) & (ndist > gap)
        lab, n = ndi.label(R)
        ids = np.unique(lab[self.tmask])
        ids = ids[ids > 0]
        R = np.isin(lab, ids)
        # fill holes that hold no neighbour (the group's own courtyards)
        holes, nh = ndi.label(ndi.binary_fill_holes(R) & ~R)
        for h in range(1, nh + 1):
            hm = holes == h
            if not (hm & self.nmask).any():
                R |= hm
        R = ndi.binary_opening(R, iterations=4) | (self.tmask & R)
        lab, n = ndi.label(R)
        ids = np.unique(lab[self.tmask])
        R = np.isin(lab, ids[ids > 0])
        gen = contourpy.contour_generator(z=np.pad(R, 1).astype(float))
        lines = gen.lines(0.5)
        ring = max(lines, key=len)
        ring = (ring - 1 + 0.5) * RES + [g.x0, g.y0]
        # test points: target cells must be inside, neighbour cells (dilated by 1.5 m) outside
        tj, ti = np.nonzero(self.tmask)
        tpts = np.column_stack(g.xy(ti, tj))[::7]
        nnear = (ndist <= 1.0) & (tdil <= REGION_MARGIN + 5)
        nj, ni = np.nonzero(nnear)
        npts = np.column_stack(g.xy(ni, nj))[::3]
        for eps in (1.0, 0.75, 0.5, 0.35, 0.25):
            poly = simplify_ring(ring, eps)
            if len(poly) < 3 or not is_simple(poly):
                continue
            if points_in_poly(poly, tpts).all() and not points_in_poly(poly, npts).any():
                break
        else:
            raise SystemExit(f"{self.name}: no valid region polygon")
        self.region = np.round(poly, 2)
        # shortest distance from the polygon's edge to a neighbour facade
        ed = []
        for k in range(len(poly)):
            a, b = poly[k], poly[(k + 1) % len(poly)]
            for s in np.linspace(0, 1, 30):
                p = a + s * (b - a)
                i, j = g.ij(p[0], p[1])
                if 0 <= i < g.nx and 0 <= j < g.ny:
                    ed.append(ndist[j, i])
        self.region_gap = float(min(ed))
        inside = self._cells_in_poly(self.region)
        self.zmin = float(self.terrain_z[inside].min()) + 0.5 if self.terrain is not None else 0.5
        self.top_target = max(float(p[3][:, 2].max()) for p in self.parts if p[5])
        self.zmax = math.ceil(self.top_target + 5.0)

    def _cells_in_poly(self, poly):
        g = self.grid
        mn = np.floor((poly.min(0) - [g.x0, g.y0]) / RES).astype(int)
        mx = np.ceil((poly.max(0) - [g.x0, g.y0]) / RES).astype(int)
        out = np.zeros((g.ny, g.nx), bool)
        ii = np.arange(max(mn[0], 0), min(mx[0], g.nx))
        jj = np.arange(max(mn[1], 0), min(mx[1], g.ny))
        I, J = np.meshgrid(ii, jj)
        pts = np.column_stack(g.xy(I.ravel(), J.ravel()))
        out[J.ravel(), I.ravel()] = points_in_poly(poly, pts)
        return out

    # ------------------------------------------------------------------ truth samples and LOS
    def scene_tris(self):
        T = [V[F] for (oid, lab, ref, V, F, tgt) in self.parts]
        if self.terrain is not None:
            ref, Vt, Ft = self.terrain
            T.append(Vt[Ft])
        else:
            lo, hi = self.cut_min - self.origin[:2], self.cut_max - self.origin[:2]
            T.append(np.array([[[lo[0], lo[1], 0], [hi[0], lo[1], 0], [hi[0], hi[1], 0]],
                               [[lo[0], lo[1], 0], [hi[0], hi[1], 0], [lo[0], hi[1], 0]]]))
        return np.concatenate(T)

    def truth_samples(self, n=900, seed=3):
        rng = np.random.default_rng(seed)
        tris = np.concatenate([V[F] for (oid, lab, ref, V, F, tgt) in self.parts if tgt])
        nrm = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        area = 0.5 * np.linalg.norm(nrm, axis=1)
        ok = area > 1e-6
        tris, nrm, area = tris[ok], nrm[ok], area[ok]
        nrm = nrm / (2 * area[:, None])
        # faces facing down are not truth; vertical walls keep either winding
        keep = nrm[:, 2] > -0.2
        nrm[nrm[:, 2] < -0.2] *= -1  # a roof wound the other way
        keep = np.ones(len(tris), bool)
        tris, nrm, area = tris[keep], nrm[keep], area[keep]
        k = rng.choice(len(tris), size=n, p=area / area.sum())
        r1, r2 = rng.random(n), rng.random(n)
        s = np.sqrt(r1)
        P = (1 - s)[:, None] * tris[k, 0] + (s * (1 - r2))[:, None] * tris[k, 1] + (s * r2)[:, None] * tris[k, 2]
        N = nrm[k]
        # outward side: the offset point must not be inside the target's solid
        out = np.empty_like(P)
        for sgn in (1.0, -1.0):
            Q = P + sgn * 0.3 * N
            i, j = self.grid.ij(Q[:, 0], Q[:, 1])
            i = np.clip(i, 0, self.grid.nx - 1)
            j = np.clip(j, 0, self.grid.ny - 1)
            solid = self.bmask[j, i] & (Q[:, 2] < self.top[j, i] - 0.05)
            if sgn > 0:
                out[:] = np.where(solid[:, None], np.nan, Q)
            else:
                fill = np.isnan(out[:, 0]) & ~solid
                out[fill] = Q[fill]
        good = ~np.isnan(out[:, 0])
        self.tP, self.tQ = P[good], out[good]
        self.tN = (out[good] - P[good]) / 0.3
        self.total_area = float(area.sum())

    def visible_hf(self, S, step=0.4):
        """Fast LOS on the 2.5D height field: from each sensor in S (m,3) to every truth sample."""
        g = self.grid
        res = np.zeros((len(S), len(self.tQ)), bool)
        H = np.where(self.bmask, self.top, self.terrain_z)
        for a, s in enumerate(S):
            d = s[None] - self.tQ
            L = np.linalg.norm(d, axis=1)
            front = np.einsum("ij,ij->i", d, self.tN) > 0
            ns = int(L.max() / step) + 2
            t = np.linspace(0.0, 1.0, ns)[None, :, None]
            pts = self.tQ[:, None, :] + t * d[:, None, :]
            i, j = g.ij(pts[..., 0], pts[..., 1])
            inb = (i >= 0) & (i < g.nx) & (j >= 0) & (j < g.ny)
            i = np.clip(i, 0, g.nx - 1)
            j = np.clip(j, 0, g.ny - 1)
            blocked = (inb & (pts[..., 2] < H[j, i] - 0.05)).any(1)
            res[a] = front & ~blocked
        return res

    def visible_exact(self, s, tris):
        d = s[None] - self.tQ
        front = np.einsum("ij,ij->i", d, self.tN) > 0
        ends = np.repeat(s[None], len(self.tQ), 0)
        blocked = segment_blocked(tris, self.tQ, ends)
        return front & ~blocked

    # ------------------------------------------------------------------ sensors
    def centroid(self):
        j, i = np.nonzero(self.tmask)
        x, y = self.grid.xy(i, j)
        return np.array([x.mean(), y.mean()])

    def place_sensors(self, rng):
        g = self.grid
        c = self.centroid()
        tdist = ndi.distance_transform_edt(~self.tmask, sampling=RES)
        border = np.minimum.reduce([
            np.arange(g.nx)[None, :] * RES + 0 * np.arange(g.ny)[:, None],
            (g.nx - 1 - np.arange(g.nx))[None, :] * RES + 0 * np.arange(g.ny)[:, None],
            np.arange(g.ny)[:, None] * RES + 0 * np.arange(g.nx)[None, :],
            (g.ny - 1 - np.arange(g.ny))[:, None] * RES + 0 * np.arange(g.nx)[None, :]])
        # ---- base stations: facade mounts 1.5 m in front of a neighbour, or roof mounts
        cand = []
        jj, ii = np.nonzero((self.dist_b >= 1.25) & (self.dist_b <= 1.75) & (border > 15) &
                            (tdist >= 12) & (tdist <= 70))
        sel = rng.permutation(len(ii))[:1500]
        for j, i in zip(jj[sel], ii[sel]):
            nj, ni = self.near_idx[0][j, i], self.near_idx[1][j, i]
            if self.tmask[nj, ni]:
                continue  # on the target itself: no
            x, y = g.xy(i, j)
            fx, fy = g.xy(ni, nj)
            n = np.array([x - fx, y - fy])
            n /= np.linalg.norm(n) + 1e-9
            to_t = c - [x, y]
            to_t /= np.linalg.norm(to_t)
            if n @ to_t < 0.4:
                continue  # the facade does not face the group
            gz = self.terrain_z[j, i]
            hmax = min(self.top[nj, ni] - 0.5 - gz, 25.0)
            for h in (8.0, 12.0, 16.0, 20.0, 25.0):
                if h <= hmax:
                    cand.append((x, y, gz + h, "facade"))
        # roof mounts: 1.5 m inside a neighbour's roof edge, 2 m above the roof
        inner = ndi.distance_transform_edt(self.bmask, sampling=RES)
        jj, ii = np.nonzero(self.nmask & (inner >= 1.25) & (inner <= 1.75) & (border > 15) &
                            (tdist >= 12) & (tdist <= 70))
        sel = rng.permutation(len(ii))[:500]
        for j, i in zip(jj[sel], ii[sel]):
            x, y = g.xy(i, j)
            gz = self.terrain_z[j, i]
            z = self.top[j, i] + 2.0
            # the roof must be flat-ish here and the mast height above ground 8..25 m
            if 8.0 <= z - gz <= 25.0:
                win = self.top[max(j - 8, 0):j + 9, max(i - 8, 0):i + 9]
                if np.all(win < z - 0.5):
                    cand.append((x, y, z, "roof"))
        cand = np.array([(a, b, z) for a, b, z, k in cand]), [k for *_, k in cand]
        C, kinds = cand
        V = self.visible_hf(C)
        w = np.ones(len(self.tQ))
        az = np.degrees(np.arctan2(C[:, 1] - c[1], C[:, 0] - c[0]))
        chosen = []
        covered = np.zeros(len(self.tQ), bool)
        for sep in (70.0, 55.0, 40.0, 25.0, 0.0):
            while len(chosen) < 4:
                gain = (V & ~covered).sum(1) + 0.35 * V.sum(1)
                for k in chosen:
                    dd = np.abs((az - az[k] + 180) % 360 - 180)
                    gain[dd < sep] = -1
                k = int(np.argmax(gain))
                if gain[k] < 0:
                    break
                chosen.append(k)
                covered |= V[k]
            if len(chosen) == 4:
                break
        self.bs_idx = list(chosen)
        self.bs = []
        for k in sorted(chosen, key=lambda k: az[k]):
            x, y, z = C[k]
            bore = math.degrees(math.atan2(c[1] - y, c[0] - x))
            self.bs.append(dict(pos=np.array([x, y, z]), bore=bore, kind=kinds[k]))
        bsV = V[chosen].any(0)
        # ---- vehicles: 3 m tracks along the street on free ground
        gy, gx = np.gradient(self.dist_b)
        jj, ii = np.nonzero((self.dist_b >= 2.5) & (border > 15) & (tdist >= 4) & (tdist <= 30))
        sel = rng.permutation(len(ii))[:2500]
        VC = []
        for j, i in zip(jj[sel], ii[sel]):
            x, y = g.xy(i, j)
            track = self.street_track(i, j, gx, gy, 1.5, 7, 2.0)
            if track is None:
                continue
            dvec, _ = track
            gz = self.terrain_z[j, i]
            # keep the track horizontal: both ends at the centre's ground + 1.5 m
            VC.append((x, y, gz + 1.5, dvec[0], dvec[1]))
        VC = np.array(VC)
        VV = self.visible_hf(VC[:, :3])
        azv = np.degrees(np.arctan2(VC[:, 1] - c[1], VC[:, 0] - c[0]))
        chosen = []
        cov = np.zeros(len(self.tQ), bool)
        for sep in (60.0, 45.0, 30.0, 15.0, 0.0):
            while len(chosen) < 5:
                pv = VV & bsV[None]
                gain = (pv & ~cov).sum(1) + 0.25 * pv.sum(1)
                for k in chosen:
                    dd = np.abs((azv - azv[k] + 180) % 360 - 180)
                    gain[dd < sep] = -1
                k = int(np.argmax(gain))
                if gain[k] < 0:
                    break
                chosen.append(k)
                cov |= pv[k]
            if len(chosen) == 5:
                break
        self.veh = []
        for k in sorted(chosen, key=lambda k: azv[k]):
            x, y, z, dx, dy = VC[k]
            d = np.array([dx, dy, 0.0])
            p = np.array([x, y, z])
            self.veh.append(dict(start=p - 1.5 * d, end=p + 1.5 * d))
        # ---- UAV: 20 m above the group's highest roof, 3 m track along x, placed for coverage
        z = self.top_target + 20.0
        UC = []
        for dx in (-15, -8, 0, 8, 15):
            for dy in (-15, -8, 0, 8, 15):
                UC.append((c[0] + dx, c[1] + dy, z))
        UC = np.array(UC)
        UVraw = self.visible_hf(UC)
        UV = UVraw & bsV[None]
        k = int(np.argmax((UV & ~cov).sum(1) + 0.25 * UV.sum(1)))
        # coordinate descent on what the pairs observe together: every base station hears every
        # aperture, so that is (union of the stations' views) & (union of the apertures' views)
        bs_sel = list(self.bs_idx)
        v_sel = list(chosen)
        u_sel = k

        def sep_ok(azs, sel, slot, cand, minsep):
            d = np.ones(len(cand), bool)
            for m, o in enumerate(sel):
                if m != slot:
                    d &= np.abs((azs[cand] - azs[o] + 180) % 360 - 180) >= minsep
            return d
        for _ in range(3):
            for slot in range(len(bs_sel)):
                ap = VV[v_sel].any(0) | UVraw[u_sel]
                other = V[[b for m, b in enumerate(bs_sel) if m != slot]].any(0)
                sc = ((other[None] | V) & ap[None]).sum(1).astype(float)
                sc[~sep_ok(az, bs_sel, slot, np.arange(len(V)), 40.0)] = -1
                bs_sel[slot] = int(np.argmax(sc))
            bsu = V[bs_sel].any(0)
            for slot in range(len(v_sel)):
                other = VV[[b for m, b in enumerate(v_sel) if m != slot]].any(0) | UVraw[u_sel]
                sc = ((other[None] | VV) & bsu[None]).sum(1).astype(float) + 0.01 * VV.sum(1)
                sc[~sep_ok(azv, v_sel, slot, np.arange(len(VV)), 25.0)] = -1
                v_sel[slot] = int(np.argmax(sc))
            other = VV[v_sel].any(0)
            u_sel = int(np.argmax(((other[None] | UVraw) & bsu[None]).sum(1)))
        self.bs = []
        for kk in sorted(bs_sel, key=lambda kk: az[kk]):
            x, y, zz = C[kk]
            bore = math.degrees(math.atan2(c[1] - y, c[0] - x))
            self.bs.append(dict(pos=np.array([x, y, zz]), bore=bore, kind=kinds[kk]))
        self.veh = []
        for kk in sorted(v_sel, key=lambda kk: azv[kk]):
            x, y, zz, dx, dy = VC[kk]
            d = np.array([dx, dy, 0.0])
            p = np.array([x, y, zz])
            self.veh.append(dict(start=p - 1.5 * d, end=p + 1.5 * d))
        p = UC[u_sel]
        self.uav = dict(start=p - [1.5, 0, 0], end=p + [1.5, 0, 0])

    def check_los(self):
        """Exact ray casts against the whole cut scene; returns {sensor: share of truth seen}."""
        tris = self.scene_tris()
        out = {}
        vis = {}
        for i, b in enumerate(self.bs, 1):
            v = self.visible_exact(b["pos"], tris)
            vis["BS%d" % i] = v
        for i, a in enumerate(self.veh, 1):
            v = self.visible_exact(0.5 * (a["start"] + a["end"]), tris)
            vis["V%d" % i] = v
        vis["UAV"] = self.visible_exact(0.5 * (self.uav["start"] + self.uav["end"]), tris)
        for k, v in vis.items():
            out[k] = float(v.mean())
        bsv = np.any([vis[k] for k in vis if k.startswith("BS")], axis=0)
        apv = np.any([vis[k] for k in vis if not k.startswith("BS")], axis=0)
        pair = np.zeros(len(self.tQ), bool)
        for kb in [k for k in vis if k.startswith("BS")]:
            for ka in [k for k in vis if not k.startswith("BS")]:
                pair |= vis[kb] & vis[ka]
        out["pairs"] = float(pair.mean())
        self.los = out
        return out

    def street_track(self, i, j, gx, gy, half, n, clearance):
        """A straight track through raster cell (i, j) along the street (across the gradient of
        the distance to the buildings), `half` metres each way, sampled at `n` points that all keep
        `clearance` metres from every building: (direction, points), or None."""
        g = self.grid
        gr = np.array([gx[j, i], gy[j, i]])
        if np.linalg.norm(gr) < 1e-6:
            return None
        d = np.array([-gr[1], gr[0]]) / np.linalg.norm(gr)
        x, y = g.xy(i, j)
        pts = [np.array([x, y]) + s * half * d for s in np.linspace(-1, 1, n)]
        for e in pts:
            ei, ej = g.ij(e[0], e[1])
            if not (0 <= ei < g.nx and 0 <= ej < g.ny) or self.dist_b[ej, ei] < clearance:
                return None
        return d, pts

    def place_target_track(self):
        """The moving target of `has-sim localize` (flat sites): a 20 m straight track on a street
        near the group, in line of sight of a base station (the monostatic sensing BS: BS1, else
        the next one that has such a track) at 20-50 m, within
        +-25 deg of the boresight that points at the track's middle, with 4 m of free ground
        (the 3 m target cylinder plus 1 m) all along. Deterministic: the candidate nearest the
        group, ties by raster order."""
        g = self.grid
        tdist = ndi.distance_transform_edt(~self.tmask, sampling=RES)
        gy, gx = np.gradient(self.dist_b)
        tris = self.scene_tris()
        jj, ii = np.nonzero((self.dist_b >= 5.0) & (tdist >= 5.0) & (tdist <= 40.0))
        order = np.lexsort((ii, jj, tdist[jj, ii]))
        half = 10.0
        for n, b in enumerate(self.bs, 1):
            if self._track_for(n, b["pos"], g, jj, ii, order, gx, gy, half, tris):
                return
        raise RuntimeError(f"{self.name}: no target track in sight of a base station")

    def _track_for(self, n, bs, g, jj, ii, order, gx, gy, half, tris):
        for k in order[::7]:
            j, i = jj[k], ii[k]
            x, y = g.xy(i, j)
            track = self.street_track(i, j, gx, gy, half, 21, 4.0)
            if track is None:
                continue
            _, pts = track
            rng_h = [np.hypot(*(e - bs[:2])) for e in pts]
            if min(rng_h) < 20.0 or max(rng_h) > 50.0:
                continue
            mid = np.array([x, y])
            bore = math.atan2(mid[1] - bs[1], mid[0] - bs[0])
            az = [math.atan2(e[1] - bs[1], e[0] - bs[0]) for e in pts]
            if max(abs((a - bore + math.pi) % (2 * math.pi) - math.pi) for a in az) > math.radians(25.0):
                continue
            # line of sight from the BS to the target's top and middle along the whole track
            ends = np.array([[e[0], e[1], h] for e in pts for h in (1.5, 3.0)])
            origins = np.repeat(bs[None], len(ends), axis=0)
            if segment_blocked(tris, origins, ends).any():
                continue
            self.target = dict(start=np.array([*pts[0], 0.0]), end=np.array([*pts[-1], 0.0]),
                               bore=math.degrees(bore), range=(min(rng_h), max(rng_h)), bs=n, pos=bs)
            return True
        return False

    def inside_building(self, p):
        i, j = self.grid.ij(p[0], p[1])
        return bool(self.bmask[j, i] and p[2] < self.top[j, i] + 0.1)

    # ------------------------------------------------------------------ writing
    def write(self):
        d = os.path.join(OUT, self.name)
        md = os.path.join(d, "meshes")
        os.makedirs(md, exist_ok=True)
        for f in os.listdir(md):
            os.remove(os.path.join(md, f))
        refs = sorted(set(p[2] for p in self.parts) | ({self.terrain[0]} if self.terrain else set()))
        L = ['<scene version="2.1.0">',
             f'<!-- {self.name}: cut from the Sionna RT {SIONNA_VERSION} scene "{self.city}" by',
             '     tools/real_sites/extract.py. Building geometry (c) OpenStreetMap contributors, ODbL 1.0;',
             '     meshes from the Sionna RT scenes (NVIDIA, Apache-2.0). Local frame: scene frame minus',
             f'     ({self.origin[0]:g}, {self.origin[1]:g}, {self.origin[2]:g}) m. -->', '']
        for r in refs:
            ty, th = self.bsdfs[r]
            L.append(f'\t<bsdf type="itu-radio-material" id="{r}">')
            L.append(f'\t\t<string name="type" value="{ty}"/>')
            if th is not None:
                L.append(f'\t\t<float name="thickness" value="{th}"/>')
            L.append('\t</bsdf>')
        L.append('')
        shapes = [(oid, ref, V, F) for (oid, lab, ref, V, F, tgt) in self.parts]
        if self.terrain is not None:
            shapes.append(("ground", self.terrain[0], self.terrain[1], self.terrain[2]))
        for oid, ref, V, F in shapes:
            fn = f"meshes/{oid}.ply"
            Vc, Fc = compact(V, F)
            write_ply(os.path.join(d, fn), Vc, Fc)
            L.append(f'\t<shape type="ply" id="mesh-{oid}">')
            L.append(f'\t\t<string name="filename" value="{fn}"/>')
            L.append('\t\t<boolean name="face_normals" value="true"/>')
            L.append(f'\t\t<ref id="{ref}" name="bsdf"/>')
            L.append('\t</shape>')
        L.append('</scene>')
        open(os.path.join(d, "scene.xml"), "w").write("\n".join(L) + "\n")
        open(os.path.join(OUT, self.name + ".toml"), "w").write(self.toml())

    def stats(self):
        fp = self.tmask.sum() * RES * RES
        heights = []
        for t in self.targets:
            zs = np.concatenate([p[3][:, 2] for p in self.parts if p[0].startswith("t_" + t + "-") or p[0] == "t_" + t])
            heights.append(zs.max() - zs.min())
        return fp, heights

    def toml(self):
        f = lambda v: "[" + ", ".join(f"{x:.2f}" for x in v) + "]"
        fp, heights = self.stats()
        lo, hi = self.cut_min - self.origin[:2], self.cut_max - self.origin[:2]
        truth = [p[0] for p in self.parts if p[5]]
        rmin = self.region.min(0)
        rmax = self.region.max(0)
        ground_note = ("flat ground z = 0 in the scene: a known ground rectangle" if self.terrain is None else
                       "terrain: the scene's Terrain mesh cut to the square (not flat), object 'ground'")
        o = []
        o.append(f"# Real-geometry site '{self.name}' ({self.city}), written by tools/real_sites/extract.py")
        o.append(f"# (Sionna RT {SIONNA_VERSION} scene '{self.city}'; do not edit by hand, regenerate).")
        o.append("# Building geometry (c) OpenStreetMap contributors, ODbL 1.0; meshes from the Sionna RT")
        o.append("# scenes (NVIDIA, Apache-2.0).")
        o.append(f"# {self.note}.")
        o.append(f"# Target group: {', '.join(self.targets)}; footprint {fp:.0f} m^2, heights "
                 f"{', '.join('%.1f' % h for h in heights)} m; {len(self.keep) - len(self.targets)} neighbour buildings in the cut.")
        o.append(f"# Local frame = scene frame minus ({self.origin[0]:g}, {self.origin[1]:g}, {self.origin[2]:g}) m; "
                 f"cut square {f(lo)}..{f(hi)} m.")
        o.append(f"# Ground: {ground_note}.")
        o.append(f"# Region: the group plus {REGION_MARGIN:g} m of street around it, ending {self.region_gap:.1f} m "
                 f"from the nearest neighbour facade (group-neighbour clearance {self.clearance:.1f} m).")
        o.append("# Line of sight to the target's surface (exact ray casts, share of truth samples): " +
                 ", ".join(f"{k} {100 * v:.0f} %" for k, v in self.los.items()))
        o.append("")
        o.append(f'description = "real site {self.name} ({self.city}, OSM via Sionna RT): {", ".join(self.targets)}"')
        o.append("")
        o.append("[scene]")
        o.append(f'description = "{self.city} cut {self.name}: {len(self.keep)} buildings"')
        o.append("")
        if self.terrain is None:
            o.append("[[scene.objects]]")
            o.append('kind = "ground"')
            o.append('name = "ground"')
            o.append('material = "concrete"')
            o.append(f"min = {f(lo)}")
            o.append(f"max = {f(hi)}")
            o.append("z = 0.0")
            o.append("")
        o.append("[[scene.objects]]")
        o.append('kind = "mesh"')
        o.append(f'path = "{self.name}/scene.xml"')
        o.append("")
        o.append(RADAR)
        for i, b in enumerate(self.bs, 1):
            o.append("[[base_stations]]")
            o.append(f'name = "BS{i}"')
            o.append(f"# {b['kind']} mount, {b['pos'][2] - self.ground_at(b['pos'][0], b['pos'][1]):.1f} m above the ground")
            o.append(f"position = {f(b['pos'])}")
            o.append(f"boresight_deg = {b['bore']:.1f}")
            o.append("")
        for i, a in enumerate(self.veh, 1):
            o.append("[[apertures]]")
            o.append(f'name = "V{i}"')
            o.append('kind = "vehicle"')
            o.append(f"start = {f(a['start'])}")
            o.append(f"end = {f(a['end'])}")
            o.append("")
        o.append("[[apertures]]")
        o.append('name = "UAV"')
        o.append('kind = "uav"')
        o.append(f"start = {f(self.uav['start'])}")
        o.append(f"end = {f(self.uav['end'])}")
        o.append("")
        o.append("[imaging]")
        o.append(f"region_min = [{rmin[0]:.2f}, {rmin[1]:.2f}, {self.zmin:.2f}]")
        o.append(f"region_max = [{rmax[0]:.2f}, {rmax[1]:.2f}, {self.zmax:.2f}]")
        o.append("region_polygon = [" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in self.region) + "]")
        o.append(IMAGING_A)
        o.append('ground_objects = ["ground"]')
        o.append(IMAGING_B)
        o.append("truth_objects = [" + ", ".join(f'"{t}"' for t in truth) + "]")
        o.append(IMAGING_C)
        if self.terrain is None:
            b = self.bs[0]
            c = self.centroid()
            pad = 25.0
            ulo = np.maximum(self.region.min(0) - pad, lo + 5)
            uhi = np.minimum(self.region.max(0) + pad, hi - 5)
            o.append("")
            o.append("# Channel prediction: the BS at BS1, 500 UEs at 1.5 m in a rectangle around the group; the")
            o.append("# twin is the reconstruction of the group plus the neighbours as mapped (known objects).")
            o.append("[channel]")
            o.append(f"bs_position = {f(b['pos'])}")
            o.append(f"bs_boresight_deg = {b['bore']:.1f}")
            o.append(f"ue_region_min = {f(ulo)}")
            o.append(f"ue_region_max = {f(uhi)}")
            # The map's buildings outside the group are known to the twin (an operator has them
            # from OSM); the twin refines the group it imaged.
            known = ["ground"] + [p[0] for p in self.parts if not p[5]]
            o.append("known_objects = [" + ", ".join(f'"{k}"' for k in known) + "]")
            o.append(CHANNEL)
            t = self.target
            o.append("")
            o.append(f"# Moving-target sensing: BS{t['bs']} monostatic, a 3 m metal cylinder on a 20 m track of a street")
            o.append(f"# near the group, {t['range'][0]:.0f}-{t['range'][1]:.0f} m from the BS in line of sight; the prior is the twin of the")
            o.append("# group plus the neighbours as mapped (known objects).")
            o.append("[localize]")
            o.append(f"position = {f(t['pos'])}")
            o.append(f"boresight_deg = {t['bore']:.1f}")
            o.append(f"track_start = {f(t['start'])}")
            o.append(f"track_end = {f(t['end'])}")
            o.append("known_objects = [" + ", ".join(f'"{k}"' for k in known[1:]) + "]")
            o.append(LOCALIZE)
        return "\n".join(o) + "\n"


RADAR = """[radar]
fc_ghz = 10.0
bandwidth_mhz = 400.0
subcarriers = 1024
zero_pad = 2
window = "hann"
snr_db = 10.0
"""
IMAGING_A = """voxel_m = 0.25
coarse_voxel_m = 1.0
coarse_threshold_db = -20.0
threshold_db = -15.0
local_max = true
element_step = 2
position_step = 2
scatterer_density_per_m2 = 16.0"""
IMAGING_B = """ground_density_per_m2 = 2.0
ground_margin_m = 10.0"""
IMAGING_C = """truth_density_per_m2 = 16.0
visibility_shift_m = 0.5
fusion_min_weight = 0.0
seed = 1

[quick]
voxel_m = 0.5
coarse_voxel_m = 1.5
element_step = 4
position_step = 4
scatterer_density_per_m2 = 6.0
truth_density_per_m2 = 9.0"""
CHANNEL = """ues = 500
ue_height_m = 1.5
seed = 7
max_loss_db = 110.0
window_db = 20.0
max_order = 3
sbr_rays = 200000
facet_angle_deg = 85.0
facet_dist_m = 0.5
codebook_rows = 32
codebook_cols = 32
codebook_spacing_wl = 0.5
match_delay_ns = 1.0
match_angle_deg = 1.0

[channel.quick]
ues = 100
max_order = 2
sbr_rays = 50000"""


LOCALIZE = """rows = 32
cols = 32
spacing_wavelengths = 0.5
fc_ghz = 10.0
bandwidth_mhz = 100.0
subcarriers = 256
zero_pad = 2
window = "hann"
symbols = 32
symbol_interval_ms = 1.0
frames = 16
tx_power_dbm = 30.0
noise_figure_db = 7.0
target_radius_m = 3.0
target_height_m = 3.0
target_speed_mps = 1.4
target_material = "metal"
target_density_per_m2 = 4.0
ground_objects = ["ground"]
building_density_per_m2 = 4.0
ground_density_per_m2 = 1.0
clutter_range_m = 110.0
range_min_m = 8.0
range_max_m = 70.0
fov_azimuth_deg = 60.0
fov_elevation_deg = [-45.0, 15.0]
angle_fft = 64
doppler_fft = 64
eca_batch = 8
eca_extra = 4
cfar_train = 12
cfar_guard = 3
cfar_pfa = 1e-6
extent_db = 12.0
false_alarm_gate_m = 3.0
twin_ground_z = 0.0
twin_density_per_m2 = 4.0
templates = 8
gate_cnr_db = 40.0
clutter_margin_db = 15.0
seed = 7

[localize.quick]
frames = 5
symbols = 16
eca_batch = 4
eca_extra = 2
ground_density_per_m2 = 0.5
building_density_per_m2 = 2.0
twin_density_per_m2 = 2.0"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sites", default="", help="comma-separated site names (default: all)")
    ap.add_argument("--scenes", default=None, help="Sionna RT scenes directory (default: the installed package's)")
    a = ap.parse_args()
    scenes = a.scenes
    if scenes is None:
        import importlib.util
        spec = importlib.util.find_spec("sionna.rt")
        scenes = os.path.join(os.path.dirname(spec.origin), "scenes")
    try:
        from importlib.metadata import version
        v = version("sionna-rt")
        if v != SIONNA_VERSION:
            print(f"warning: sionna-rt {v} installed, sites were made with {SIONNA_VERSION}", file=sys.stderr)
    except Exception:
        pass
    want = [s for s in a.sites.split(",") if s]
    cache = {}
    for name, city, targets, note in SITES:
        if want and name not in want:
            continue
        if city not in cache:
            cache[city] = read_scene(scenes, city)
        s = Site(name, city, targets, note, cache[city])
        s.build()
        s.make_region()
        s.truth_samples()
        rng = np.random.default_rng(abs(hash(name)) % 2**32 if False else sum(map(ord, name)))
        s.place_sensors(rng)
        for p in [b["pos"] for b in s.bs] + [v["start"] for v in s.veh] + [v["end"] for v in s.veh] + \
                [s.uav["start"], s.uav["end"]]:
            assert not s.inside_building(p), (name, p)
        los = s.check_los()
        if s.terrain is None:
            s.place_target_track()
        s.write()
        fp, heights = s.stats()
        print(f"{name}: {len(s.keep)} buildings, footprint {fp:.0f} m2, heights "
              f"{'/'.join('%.1f' % h for h in heights)} m, region gap {s.region_gap:.1f} m, "
              f"region {len(s.region)} vertices, LOS " +
              " ".join(f"{k}={100 * v:.0f}%" for k, v in los.items()), flush=True)


if __name__ == "__main__":
    main()
