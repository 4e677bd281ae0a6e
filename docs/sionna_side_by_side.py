"""has against Sionna RT on Sionna's bundled scenes: paths found by each, |delta tau|, |delta gain|.

Not part of has (nothing in the workspace calls it): a peer check to rerun by hand, in a scratch
venv with `pip install sionna-rt` (2.2.0 measured; drjit needs an LLVM >= 16 at run time, e.g.
Debian's libllvm19 with DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so).

    python docs/sionna_side_by_side.py target/release/has-sim [OTHER_HAS_SIM ...]

Both trace order <= 3 specular paths at 3.5 GHz between isotropic V-polarised antennas; has
reads the same XML file directly (`has-sim paths --scene FILE.xml --json`). Sionna paths are
matched to has paths by delay (within 0.01 ns); gains are 20 log10 |a| of Sionna's
`cir(normalize_delays=False)`, which has's `a` equals. Prints one JSON line per case and writes
rows.json.
"""
import sys, json, subprocess, numpy as np
import sionna.rt as rt
from sionna.rt import load_scene, PlanarArray, Transmitter, Receiver, PathSolver
F=3.5e9
HAS=sys.argv[1:]  # binaries
def sionna_paths(name, tx, rx):
    scene = load_scene(getattr(rt.scene, name))
    scene.frequency = F
    arr = PlanarArray(num_rows=1, num_cols=1, pattern="iso", polarization="V")
    scene.tx_array = arr; scene.rx_array = arr
    scene.add(Transmitter("tx", position=list(tx)))
    scene.add(Receiver("rx", position=list(rx)))
    p = PathSolver()(scene, max_depth=3, los=True, specular_reflection=True, diffuse_reflection=False,
                     refraction=False, diffraction=False, synthetic_array=True, samples_per_src=1_000_000)
    a, tau = p.cir(normalize_delays=False, out_type="numpy")
    a = np.asarray(a)[0, 0, 0, 0, :, 0]
    tau = np.asarray(tau)[0, 0, :]
    keep = np.abs(a) > 0
    return tau[keep]*1e9, 20*np.log10(np.abs(a[keep])), a[keep]
def has_paths(binary, xml, tx, rx):
    out = subprocess.run([binary, 'paths', '--scene', xml, '--tx', ','.join(map(str,tx)), '--rx', ','.join(map(str,rx)),
                          '--max-order', '3', '--freq-ghz', str(F/1e9), '--rays', '1000000', '--json'], capture_output=True, text=True)
    if out.returncode: return None, out.stderr.strip()
    P = json.loads(out.stdout)['paths']
    return np.array([p['delay_ns'] for p in P]), np.array([p['gain_db'] for p in P])
cases = [('simple_reflector', (-10.0, 0.0, 10.0), (10.0, 0.0, 10.0)),
         ('triple_reflector', (-10.0, 5.0, 8.0), (10.0, -5.0, 6.0))]
cases += [('simple_street_canyon', (-33.0, 11.0, 32.0), (x, y, 1.5)) for x, y in [(30.0, -8.0), (0.0, 0.0), (-20.0, -5.0), (15.0, 3.0), (40.0, 10.0), (-10.0, 2.0), (25.0, 0.0)]]
cases += [('munich', (8.5, 21.0, 27.0), (x, y, 1.5)) for x, y in [(45.0, 90.0), (20.0, 60.0), (-20.0, 40.0), (0.0, 0.0), (60.0, -20.0)]]
cases += [('etoile', (0.0, 0.0, 40.0), (x, y, 1.5)) for x, y in [(60.0, 10.0), (-40.0, 70.0), (100.0, -50.0), (30.0, 30.0), (-80.0, 0.0)]]
rows=[]
for name, tx, rx in cases:
    xml = str(getattr(rt.scene, name))
    skip = has_paths(HAS[0], xml, tx, rx)
    if skip[0] is None:
        print(json.dumps({'scene': name, 'tx': tx, 'rx': rx, 'skipped': skip[1]}), flush=True); continue
    st, sg, _ = sionna_paths(name, tx, rx)
    line = {'scene': name, 'tx': tx, 'rx': rx, 'sionna_paths': int(len(st))}
    for b in HAS:
        ht, hg = has_paths(b, xml, tx, rx)
        matched=[]
        for t, g in zip(st, sg):
            if len(ht)==0: continue
            j = np.argmin(np.abs(ht - t))
            if abs(ht[j]-t) < 0.01: matched.append((abs(ht[j]-t), hg[j]-g))
        m=np.array(matched) if matched else np.zeros((0,2))
        line[b] = {'has_paths': int(len(ht)), 'matched': int(len(m)),
                   'max_dtau_ns': float(m[:,0].max()) if len(m) else None,
                   'max_dgain_db': float(np.abs(m[:,1]).max()) if len(m) else None,
                   'median_dgain_db': float(np.median(np.abs(m[:,1]))) if len(m) else None}
    rows.append(line); print(json.dumps(line), flush=True)
json.dump(rows, open('rows.json', 'w'), indent=1)
