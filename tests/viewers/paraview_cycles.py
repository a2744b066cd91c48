"""What a ParaView user sees of an adaptive run's results, with ParaView's default reader.

    xvfb-run -a pvpython tests/viewers/paraview_cycles.py DIR PREFIX_NAME CELLS_1,CELLS_2,...

Opens DIR/PREFIX_NAME.xdmf (the cycles' time series) from DIR by a relative name and checks:
the reader is the default one for .xdmf; the time steps are the cycle numbers 1 .. K; at each,
one grid with that cycle's cell count (CELLS_k: each cycle its own mesh) and the fields
(displacement, stress, eta_glo, eta_fe, eta_nndd, body); PREFIX_NAME-final.xdmf opens without
time steps with the last cycle's cells. Prints one line per check, exits 1 on the first failure.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import arrays, check, leaves  # noqa: E402

from paraview import servermanager as sm
from paraview.simple import OpenDataFile

directory, name, cells = sys.argv[1], sys.argv[2], [int(c) for c in sys.argv[3].split(",")]
os.chdir(directory)


FIELDS = {"displacement", "stress", "eta_glo", "eta_fe", "eta_nndd", "body"}
series = OpenDataFile("./" + name + ".xdmf")
check(series is not None and series.GetXMLName() == "Xdmf3ReaderS",
      f"./{name}.xdmf opens with the default reader ({series.GetXMLName()})")
times = list(series.TimestepValues)
check(times == [float(k) for k in range(1, len(cells) + 1)],
      f"time steps are the cycles 1 .. {len(cells)}: {times}")
for t, n in zip(times, cells):
    series.UpdatePipeline(t)
    ds = leaves(sm.Fetch(series))
    check(len(ds) == 1 and ds[0].GetNumberOfCells() == n and FIELDS <= set(arrays(ds[0])),
          f"cycle {t:g}: one grid of {ds[0].GetNumberOfCells()} cells (its mesh: {n}) with the fields")
final = OpenDataFile("./" + name + "-final.xdmf")
ds = leaves(sm.Fetch(final))
check(len(list(final.TimestepValues)) == 0 and len(ds) == 1
      and ds[0].GetNumberOfCells() == cells[-1] and FIELDS <= set(arrays(ds[0])),
      f"./{name}-final.xdmf: the last cycle alone ({ds[0].GetNumberOfCells()} cells)")
