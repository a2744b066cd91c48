"""meshio reads nndd's results: every step of every function of PREFIX.xdmf and
PREFIX-contact.xdmf (TimeSeriesReader), and PREFIX-final.xdmf (meshio.read), with the values
of the HDF5 file (h5py).

    python3 tests/viewers/meshio_check.py PREFIX ITERATIONS

Prints what it read, exits 1 on the first difference.
"""

import sys

import h5py
import meshio
import numpy as np

prefix, iterations = sys.argv[1], float(sys.argv[2])
h5 = h5py.File(prefix + ".h5", "r")


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        sys.exit(1)


for grid, xdmf, cell_type in (("bodies", prefix + ".xdmf", "triangle"),
                              ("contact", prefix + "-contact.xdmf", "line")):
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, cells = reader.read_points_cells()
        check(np.array_equal(points, h5[f"Mesh/{grid}/geometry"][...])
              and len(cells) == 1 and cells[0].type == cell_type
              and np.array_equal(cells[0].data, h5[f"Mesh/{grid}/topology"][...]),
              f"{xdmf}: the mesh ({len(points)} points, {len(cells[0].data)} {cell_type}s)")
        functions = h5[f"Function/{grid}"]
        times = sorted({float(k.replace('_', '.')) for f in functions.values() for k in f})
        check(reader.num_steps == len(times), f"{reader.num_steps} steps")
        read = 0
        for k in range(reader.num_steps):
            t, point_data, cell_data = reader.read_data(k)
            check(t == times[k], f"step {k}: time {t:g}") if k in (0, reader.num_steps - 1) else None
            data = dict(point_data)
            data.update({n: v[0] for n, v in cell_data.items()})
            for name, values in data.items():
                key = f"Function/{grid}/{name}/{t:g}"
                stored = h5[key][...] if key in h5 else h5[f"Mesh/{grid}/{name}"][...]
                if not np.array_equal(values, stored):
                    check(False, f"step {k}: {name} differs from {key}")
                read += 1
        check(t == iterations, f"the last step is the reported iterate {iterations:g}")
        expected = sum(len(f) for f in functions.values())
        constant = [n for n in h5[f"Mesh/{grid}"] if n not in ("geometry", "topology")]
        check(read == expected + len(constant) * reader.num_steps,
              f"{read} fields read, every step of every function")

mesh = meshio.read(prefix + "-final.xdmf")
eta = h5[f"Function/bodies/eta_fe/{iterations:g}"][...]
check(np.array_equal(mesh.cell_data["eta_fe"][0], eta)
      and np.array_equal(mesh.point_data["displacement"],
                         h5[f"Function/bodies/displacement/{iterations:g}"][...]),
      f"{prefix}-final.xdmf: {len(mesh.points)} points, "
      f"{sorted(mesh.point_data)} {sorted(mesh.cell_data)}")
