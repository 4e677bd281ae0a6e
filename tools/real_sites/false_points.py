#!/usr/bin/env python3
"""Where a real site's false points lie: a run's fused cloud (`reconstruct ... --out RUN`) against
its truth samples. A point is false when it lies more than 1.5 m from every truth sample; false
points are classed as inside the target buildings' footprint and more than 1 m below their top,
more than 1.5 m above their top, within 4 m of the region polygon's edge, or other.

    python tools/real_sites/false_points.py RUN fixtures/real/SITE.toml

Needs numpy, scipy, trimesh, matplotlib (a scratch venv; not a dependency of has).
"""
import sys, numpy as np, trimesh, tomllib
from scipy.spatial import cKDTree
from matplotlib.path import Path
run, toml = sys.argv[1], sys.argv[2]
sc = tomllib.load(open(toml,'rb'))
base = toml.rsplit('/',1)[0]
site = toml.rsplit('/',1)[1][:-5]
def ply(p):
    m = trimesh.load(p, process=False)
    return m
fused = trimesh.load(f"{run}/fused.ply", process=False)
P = np.asarray(fused.vertices)
pairs = fused.metadata['_ply_raw']['vertex']['data']['pairs'] if '_ply_raw' in fused.metadata else None
gt = np.asarray(trimesh.load(f"{run}/ground_truth.ply", process=False).vertices)
d, _ = cKDTree(gt).query(P)
false = d > 1.5
# truth footprint from roof meshes (2D triangles)
tris=[]; roofz=[]
for name in sc['imaging']['truth_objects']:
    m = trimesh.load(f"{base}/{site}/meshes/{name}.ply", process=False)
    tris.append(m.vertices[m.faces]); roofz.append(m.vertices[:,2].max())
tris = np.concatenate(tris)
top = max(roofz)
inside_fp = np.zeros(len(P), bool)
for t in tris:
    inside_fp |= Path(t[:,:2]).contains_points(P[:,:2])
poly = np.array(sc['imaging']['region_polygon'])
def dist_edges(q):
    best = np.full(len(q), np.inf)
    for i in range(len(poly)):
        a, b = poly[i], poly[(i+1)%len(poly)]
        ab = b-a; t = np.clip(((q-a)@ab)/(ab@ab), 0, 1)
        best = np.minimum(best, np.linalg.norm(q-(a+t[:,None]*ab), axis=1))
    return best
de = dist_edges(P[:,:2])
cls = np.full(len(P), 'other', object)
cls[false & inside_fp & (P[:,2] < top - 1.0)] = 'inside'
cls[false & (P[:,2] > top + 1.5)] = 'above_top'
cls[false & (cls=='other') & (de < 4.0)] = 'border'
print(f"{run}: {len(P)} points, false {false.sum()} ({100*false.mean():.1f} %)")
for c in ['inside','above_top','border','other']:
    n = ((cls==c)&false).sum()
    print(f"  {c:10s} {n:6d}")
