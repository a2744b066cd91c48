"""Render the stick and slip zones of a frictional nndd result with ParaView.

    xvfb-run -a pvpython jobs/render_friction.py PREFIX OUT.png [--half-width 0.12]
        [--centre X Y] [--title TEXT]

Opens PREFIX.xdmf (the bodies) and PREFIX-contact.xdmf (Γc) with ParaView's default reader at
their last time step (the reported iterate), both deformed at true scale. The bodies around the
contact (a window of --half-width about --centre) are coloured by the shear stress σ_xy (Pa),
Γc drawn over them as a thick line coloured by `contact_state` (0 separated, grey; 1 stick,
blue; 2 slip, red). Prints the pairs in each state. The paths are made absolute (ParaView
5.11's Xdmf3 aborts on a bare relative name).
"""

import argparse
import os

from paraview import servermanager
from paraview.simple import (
    Calculator,
    Clip,
    ExtractSurface,
    ColorBy,
    CreateView,
    GetColorTransferFunction,
    GetScalarBar,
    OpenDataFile,
    Render,
    SaveScreenshot,
    Show,
    Text,
    Transform,
    Tube,
    WarpByVector,
)

RESOLUTION = [1600, 1000]


def last_time(reader):
    t = reader.TimestepValues
    return t[-1] if hasattr(t, "__len__") and len(t) else t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("prefix")
    ap.add_argument("out")
    ap.add_argument("--half-width", type=float, default=0.12)
    ap.add_argument("--centre", type=float, nargs=2, default=[0.0, 0.0])
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    prefix = os.path.abspath(a.prefix)
    bodies = OpenDataFile(prefix + ".xdmf")
    contact = OpenDataFile(prefix + "-contact.xdmf")
    t = last_time(bodies)
    view = CreateView("RenderView")
    view.ViewSize = RESOLUTION
    view.ViewTime = t
    view.OrientationAxesVisibility = 0
    view.UseColorPaletteForBackground = 0
    view.Background = [1, 1, 1]
    warped = WarpByVector(Input=bodies, Vectors=["POINTS", "displacement"], ScaleFactor=1.0)
    shear = Calculator(Input=warped, AttributeType="Cell Data", ResultArrayName="sigma_xy")
    shear.Function = "stress_XY"
    (cx, cy), h = a.centre, a.half_width
    box = Clip(Input=shear, ClipType="Box", Invert=1)
    box.ClipType.Position = [cx - h, cy - 0.6 * h, -1]
    box.ClipType.Length = [2 * h, 1.2 * h, 2]
    shown = Show(box, view)
    ColorBy(shown, ("CELLS", "sigma_xy"))
    lut = GetColorTransferFunction("sigma_xy")
    lut.ApplyPreset("Cool to Warm", True)
    box.UpdatePipeline(t)
    data = servermanager.Fetch(box)
    while data is not None and data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    rng = data.GetCellData().GetArray("sigma_xy").GetRange() if data else (-1, 1)
    m = max(abs(rng[0]), abs(rng[1]))
    lut.RescaleTransferFunction(-m, m)
    bar = GetScalarBar(lut, view)
    bar.Title = "shear stress sigma_xy (Pa)"
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0, 0, 0]
    shown.SetScalarBarVisibility(view, True)
    gc = WarpByVector(Input=contact, Vectors=["POINTS", "displacement"], ScaleFactor=1.0)
    tube = Tube(Input=ExtractSurface(Input=gc), Radius=0.0025 * h / 0.12)
    # (in front of the bodies, which lie in z = 0)
    front = Transform(Input=tube)
    front.Transform.Translate = [0, 0, 0.05]
    line = Show(front, view)
    ColorBy(line, ("POINTS", "contact_state"))
    states = GetColorTransferFunction("contact_state")
    states.InterpretValuesAsCategories = 1
    states.Annotations = ["0", "separated", "1", "stick", "2", "slip"]
    states.IndexedColors = [0.6, 0.6, 0.6, 0.1, 0.3, 0.9, 0.9, 0.1, 0.1]
    sbar = GetScalarBar(states, view)
    sbar.Title = "contact state"
    sbar.ComponentTitle = ""
    sbar.TitleColor = sbar.LabelColor = [0, 0, 0]
    sbar.WindowLocation = "Upper Left Corner"
    line.SetScalarBarVisibility(view, True)
    contact.UpdatePipeline(t)
    pairs = servermanager.Fetch(contact)
    while pairs.IsA("vtkMultiBlockDataSet"):
        pairs = pairs.GetBlock(0)
    st = pairs.GetPointData().GetArray("contact_state")
    counts = [0, 0, 0]
    for i in range(pairs.GetNumberOfPoints()):
        counts[int(round(st.GetValue(i)))] += 1
    print(f"pairs: {counts[0]} separated, {counts[1]} stick, {counts[2]} slip")
    if a.title:
        title = Text(Text=a.title)
        tv = Show(title, view)
        tv.Color = [0, 0, 0]
        tv.WindowLocation = "Upper Center"
    view.CameraPosition = [cx, cy, 10]
    view.CameraFocalPoint = [cx, cy, 0]
    view.CameraViewUp = [0, 1, 0]
    view.CameraParallelProjection = 1
    view.CameraParallelScale = 0.62 * h
    Render(view)
    SaveScreenshot(a.out, view, ImageResolution=RESOLUTION)
    print("wrote", a.out)


main()
