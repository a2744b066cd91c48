"""What a ParaView user sees of nndd's results, with ParaView's default reader.

    xvfb-run -a pvpython tests/viewers/paraview_check.py DIR PREFIX_NAME ITERATIONS PNG

Opens DIR/PREFIX_NAME.xdmf from DIR by a relative name, as OpenDataFile does for a user, and
checks: the reader is the default one for .xdmf; the time steps are iteration numbers, the last
the reported iterate ITERATIONS; the arrays are the same at every step's structure (one grid,
no renamed blocks); a rendering of eta_fe at the last step is not a single colour (written to
PNG); the stress is a 6-component tensor named XX YY ZZ XY YZ XZ; the contact grid's points
move under "Warp By Vector" by its displacement and keep their fields; PREFIX_NAME-final.xdmf
opens without time steps with the estimates' fields. Prints one line per check, exits 1 on the
first failure.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from checks import arrays, check, leaves  # noqa: E402

import numpy as np
from paraview import servermanager as sm
from paraview.simple import (
    ColorBy,
    GetActiveViewOrCreate,
    GetAnimationScene,
    OpenDataFile,
    Render,
    SaveScreenshot,
    Show,
    WarpByVector,
)
from vtk.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

directory, name, iterations, png = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
os.chdir(directory)


bodies = OpenDataFile("./" + name + ".xdmf")
check(bodies is not None and bodies.GetXMLName() == "Xdmf3ReaderS",
      f"./{name}.xdmf opens with the default reader ({bodies.GetXMLName()})")
times = list(bodies.TimestepValues)
check(len(times) >= 2 and times[-1] == iterations and times == sorted(times)
      and all(t == int(t) for t in times),
      f"time steps are iteration numbers, the last the reported iterate {iterations:g}: {times}")
structure = None
for t in (times[0], times[len(times) // 2], times[-1]):
    bodies.UpdatePipeline(t)
    ds = leaves(sm.Fetch(bodies))
    s = [(d.GetNumberOfCells(), tuple(arrays(d))) for d in ds]
    structure = structure or s
    check(len(ds) == 1 and s[0][0] > 0 and s == structure,
          f"one grid, the same arrays, at time {t:g}: {s}")
last = leaves(sm.Fetch(bodies))[0]
check({"displacement", "stress", "von_mises", "eta_glo", "eta_fe", "eta_nndd", "body"}
      <= set(arrays(last)), f"the fields at the last step: {arrays(last)}")
stress = bodies.CellData["stress"]
names = [stress.GetComponentName(i) for i in range(stress.GetNumberOfComponents())]
check(names == ["XX", "YY", "ZZ", "XY", "YZ", "XZ"], f"stress components {names}")

scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
scene.AnimationTime = times[-1]
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [600, 400]
view.OrientationAxesVisibility = 0
shown = Show(bodies, view)
view.Update()
ColorBy(shown, ("CELLS", "eta_fe"))
shown.RescaleTransferFunctionToDataRange(True, False)
view.ResetCamera()
Render(view)
SaveScreenshot(png, view, ImageResolution=[600, 400])
reader = vtkPNGReader()
reader.SetFileName(png)
reader.Update()
image = reader.GetOutput()
w, h, _ = image.GetDimensions()
pixels = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(h, w, -1)[:, :, :3]
background = pixels[0, 0]
body = pixels[(pixels != background).any(axis=2)]
colours = len({tuple(p) for p in body})
check(len(body) > 0.1 * w * h and colours >= 20,
      f"eta_fe at iteration {times[-1]:g} rendered in {colours} colours over {len(body)} pixels ({png})")

contact = OpenDataFile("./" + name + "-contact.xdmf")
check(list(contact.TimestepValues) == times, "the contact grid has the same time steps")
contact.UpdatePipeline(times[-1])
warp = WarpByVector(Input=contact)
warp.Vectors = ["POINTS", "displacement"]
warp.UpdatePipeline(times[-1])
before = leaves(sm.Fetch(contact))[0]
after = leaves(sm.Fetch(warp))[0]
p0 = vtk_to_numpy(before.GetPoints().GetData())
p1 = vtk_to_numpy(after.GetPoints().GetData())
u = vtk_to_numpy(before.GetPointData().GetArray("displacement"))
moved = np.abs(p1 - p0).max()
check(moved > 0 and np.allclose(p1 - p0, u, rtol=1e-6, atol=1e-6 * moved),
      f"Warp By Vector moves the contact points by their displacement (max {moved:.3e} m)")
check({"pressure", "gap", "displacement"} <= set(arrays(after)),
      f"the warped contact grid keeps its fields: {arrays(after)}")

final = OpenDataFile("./" + name + "-final.xdmf")
final.UpdatePipeline()
f = leaves(sm.Fetch(final))
check(not list(final.TimestepValues) and len(f) == 1
      and f[0].GetNumberOfCells() == last.GetNumberOfCells()
      and "eta_fe" in arrays(f[0]),
      f"./{name}-final.xdmf: the reported iterate alone, {arrays(f[0])}")
eta_last = vtk_to_numpy(last.GetCellData().GetArray("eta_fe"))
eta_final = vtk_to_numpy(f[0].GetCellData().GetArray("eta_fe"))
check(np.array_equal(eta_last, eta_final), "its eta_fe is the last step's")
