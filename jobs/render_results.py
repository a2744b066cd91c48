"""Render the results of an nndd run with ParaView, the pictures a new user would make.

    xvfb-run -a pvpython jobs/render_results.py PREFIX OUTDIR [--label TEXT] [--half-width W]

PREFIX is the run's -nndd_output prefix (PREFIX.xdmf, PREFIX-contact.xdmf, PREFIX.h5 must
exist). Writes into OUTDIR:
  results-displacement.png      both bodies warped by `displacement`, coloured by its magnitude
  results-von-mises.png         the same, coloured by the cell field `von_mises`
  results-eta-fe.png            the same, coloured by the cell field `eta_fe` (log scale; only
                                when the run estimated, -nndd_estimate)
  results-contact-pressure.png  the contact zone (x in [-W, W], by default all of Γc): the
                                bodies warped (grey, mesh edges) and over them Γc
                                (PREFIX-contact.xdmf) warped by its own `displacement` (its
                                pairs' side's), a thick line coloured by `pressure`
All at true scale (warp scale 1), at the last time step (the reported iterate). Nothing special
is needed: ParaView's default reader (OpenDataFile, in 5.11 Xdmf3ReaderS), WarpByVector,
ColorBy. The paths are made absolute: given a bare "hertz.xdmf" (no directory part), ParaView
5.11's Xdmf3 looks for "hertz.xdmfhertz.h5" and aborts.
"""

import argparse
import math
import os
import sys

from paraview import servermanager
from paraview.simple import (
    Clip,
    ColorBy,
    CreateView,
    GetAnimationScene,
    GetColorTransferFunction,
    GetScalarBar,
    OpenDataFile,
    Render,
    SaveScreenshot,
    SetActiveView,
    Show,
    Text,
    WarpByVector,
)

SIZE = [1600, 1000]


def fail(msg):
    sys.stderr.write(f"render_results: {msg}\n")
    sys.exit(1)


def parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("prefix", help="the run's -nndd_output prefix")
    p.add_argument("outdir", help="folder for the results-*.png")
    p.add_argument("--label", default="", help="caption text before each picture's own")
    p.add_argument("--half-width", type=float, default=None,
                   help="half-width (m) of the contact-zone picture around x = 0 (default: "
                        "all of the contact interface, 10%% to spare)")
    return p.parse_args()


def open_last(path):
    """OpenDataFile at the last time step; returns (reader, time)."""
    if not os.path.isfile(path):
        fail(f"no such file: {path}")
    reader = OpenDataFile(path)
    if reader is None:
        fail(f"ParaView found no reader for {path}")
    times = reader.TimestepValues
    times = [] if times is None else [times] if isinstance(times, (int, float)) else list(times)
    time = max(times) if times else 0.0
    reader.UpdatePipeline(time)
    print(f"render_results: {path} ({reader.GetXMLName()}): "
          f"{len(times)} time step(s), showing {time:g}; "
          f"cell fields {', '.join(reader.CellData.keys()) or '-'}; "
          f"point fields {', '.join(reader.PointData.keys()) or '-'}")
    return reader, time


def new_view(caption):
    """A white 2D render view of SIZE with a caption at the top left."""
    view = CreateView("RenderView")
    SetActiveView(view)
    view.ViewSize = SIZE
    if hasattr(view, "UseColorPaletteForBackground"):  # ParaView 5.10+
        view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.OrientationAxesVisibility = 0
    view.CameraParallelProjection = 1
    view.InteractionMode = "2D"
    text = Show(Text(Text=caption), view)
    text.Color = [0, 0, 0]
    text.FontSize = 22
    text.WindowLocation = "Upper Left Corner"
    return view


def ticks(lo, hi, n=6):
    """About n round values in [lo, hi] (steps 1, 2, 2.5 or 5 times a power of ten)."""
    raw = (hi - lo) / n
    if raw <= 0:
        return []
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step - 1e-9)
    return [k * step for k in range(first, int(math.floor(hi / step + 1e-9)) + 1)]


def scalar_bar(view, name, title):
    """The labelled bar of array `name`'s colour map, once its range is set. A linear map's bar
    is labelled at round values of that range: ParaView's own choice crowds a bar of 0 .. 0.012
    m with 25 long labels that run into the title."""
    lut = GetColorTransferFunction(name)
    bar = GetScalarBar(lut, view)
    if not lut.UseLogScale:
        lo, hi = lut.RGBPoints[0], lut.RGBPoints[-4]
        gap = 0.04 * (hi - lo)  # none so near an end that it would hit the range label
        bar.UseCustomLabels = 1
        bar.CustomLabels = [t for t in ticks(lo, hi) if lo + gap < t < hi - gap]
        bar.LabelFormat = "%-#.3g"
    bar.Title = title
    bar.ComponentTitle = ""
    bar.Visibility = 1
    bar.WindowLocation = "Any Location"
    bar.Orientation = "Vertical"
    bar.Position = [0.88, 0.12]
    bar.ScalarBarLength = 0.76
    bar.ScalarBarThickness = 24
    bar.TitleColor = bar.LabelColor = [0, 0, 0]
    bar.TitleFontSize = 24
    bar.LabelFontSize = 20
    bar.RangeLabelFormat = "%-#.3g"
    return lut


def axes(rep, view, bounds):
    """x and y labels (m) along the shown window."""
    g = rep.DataAxesGrid
    g.GridAxesVisibility = 1
    g.XTitle, g.YTitle, g.ZTitle = "x (m)", "", ""  # a y title would overlap the labels in 2D
    for attr in ("XTitleColor", "YTitleColor", "XLabelColor", "YLabelColor", "GridColor"):
        setattr(g, attr, [0, 0, 0])
    g.XTitleFontSize = 20
    g.XLabelFontSize = g.YLabelFontSize = 18
    g.UseCustomBounds = 1
    g.CustomBounds = [bounds[0], bounds[1], bounds[2], bounds[3], 0.0, 0.0]
    g.FacesToRender = 0x04 | 0x20  # the xy faces
    g.AxesToLabel = 0x01 | 0x02    # the min-x and min-y edges
    ytitle = Show(Text(Text="y (m)"), view)  # above the y axis instead
    ytitle.Color = [0, 0, 0]
    ytitle.FontSize = 20
    ytitle.WindowLocation = "Any Location"
    ytitle.Position = [75 / SIZE[0], 912 / SIZE[1]]


def fit(view, bounds):
    """Camera on the window bounds = (x0, x1, y0, y1), the plot area left of the scalar bar."""
    Render(view)  # paraview.simple resets the camera at its first render: before ours
    x0, x1, y0, y1 = bounds
    # The plot area in pixels: x 170 .. 1330, y 100 .. 900 (room for the axis labels, the
    # caption and the scalar bar); its centre is 50 px left of the view's.
    per_px = max((x1 - x0) / 1160.0, (y1 - y0) / 800.0)
    fx = 0.5 * (x0 + x1) + 50 * per_px
    fy = 0.5 * (y0 + y1)
    view.CameraPosition = [fx, fy, 10.0]
    view.CameraFocalPoint = [fx, fy, 0.0]
    view.CameraViewUp = [0.0, 1.0, 0.0]
    view.CameraParallelScale = 0.5 * SIZE[1] * per_px


def save(view, path):
    Render(view)
    SaveScreenshot(path, view, ImageResolution=SIZE, CompressionLevel="9")
    print(f"render_results: wrote {path}")


def main():
    a = parse()
    prefix = os.path.abspath(a.prefix)
    outdir = os.path.abspath(a.outdir)
    os.makedirs(outdir, exist_ok=True)
    label = a.label + ": " if a.label else ""

    bodies, time = open_last(prefix + ".xdmf")
    contact, ctime = open_last(prefix + "-contact.xdmf")
    if ctime != time:
        fail(f"the bodies' last step {time:g} is not the contact's {ctime:g}")
    scene = GetAnimationScene()  # every view shows the scene's time: the last step
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = time
    for name in ("displacement", "von_mises"):
        if name not in bodies.PointData.keys() and name not in bodies.CellData.keys():
            fail(f"{prefix}.xdmf has no field '{name}'")
    # eta_fe only where the run estimated (-nndd_estimate); without it that picture is left out.
    estimated = "eta_fe" in bodies.CellData.keys()
    if not estimated:
        print(f"render_results: {prefix}.xdmf has no 'eta_fe' (the run did not estimate): "
              "no results-eta-fe.png")
    if "pressure" not in contact.PointData.keys():
        fail(f"{prefix}-contact.xdmf has no field 'pressure'")

    warped = WarpByVector(Input=bodies, Vectors=["POINTS", "displacement"], ScaleFactor=1.0)
    warped.UpdatePipeline(time)
    b = warped.GetDataInformation().GetBounds()
    domain = (b[0], b[1], b[2], b[3])
    step = f"iteration {time:g}, deformed (true scale)"

    # 1-3: both bodies, coloured by a field each.
    pictures = [
        ("results-displacement.png", ("POINTS", "displacement", "Magnitude"), "displacement",
         "displacement magnitude", "displacement magnitude (m)", False),
        ("results-von-mises.png", ("CELLS", "von_mises"), "von_mises",
         "von Mises stress", "von Mises stress (Pa)", False),
        ("results-eta-fe.png", ("CELLS", "eta_fe"), "eta_fe",
         r"$\eta^{\mathrm{FE}}$ per element (log scale)",
         r"$\eta^{\mathrm{FE}}$ per element ($\sqrt{\mathrm{J/m}}$)", True),
    ]
    written = []
    for png, colour, name, what, title, log in pictures:
        if name == "eta_fe" and not estimated:
            continue
        view = new_view(f"{label}{what}, {step}")
        rep = Show(warped, view)
        ColorBy(rep, colour)
        lut = GetColorTransferFunction(name)
        if log:
            lut.UseLogScale = 1
            lo, hi = warped.CellData[name].GetRange()
            lut.RescaleTransferFunction(max(lo, hi * 1e-6), hi)  # a positive minimum
        else:
            rep.RescaleTransferFunctionToDataRange(False, True)
        scalar_bar(view, name, title)
        axes(rep, view, domain)
        fit(view, domain)
        path = os.path.join(outdir, png)
        save(view, path)
        written.append(path)

    # 4: the contact zone, Γc warped by its displacement over the warped bodies (grey).
    gamma = WarpByVector(Input=contact, Vectors=["POINTS", "displacement"], ScaleFactor=1.0)
    gamma.UpdatePipeline(time)
    check_on_interface(warped, gamma)
    g = gamma.GetDataInformation().GetBounds()
    cy = 0.5 * (g[2] + g[3])
    # (by default Γc's x-range, and its y-range too: a closed Γc, a whole circle, is as tall)
    w = a.half_width or 1.1 * max(abs(g[0]), abs(g[1]), 0.5 * (g[3] - g[2]) * 1160.0 / 800.0)
    h = w * 800.0 / 1160.0
    zone = (-w, w, cy - h, cy + h)
    # The bodies cut to the window, so that the picture ends where the axes do.
    window = Clip(Input=warped)
    window.ClipType = "Box"
    window.ClipType.Position = [zone[0], zone[2], -1.0]
    window.ClipType.Length = [zone[1] - zone[0], zone[3] - zone[2], 2.0]
    window.Invert = 1  # keep the inside
    window.Exact = 1
    view = new_view(f"{label}contact pressure along " + r"$\Gamma_{\mathrm{c}}$" + f", {step}")
    body_rep = Show(window, view)
    ColorBy(body_rep, None)
    body_rep.SetRepresentationType("Surface With Edges")
    body_rep.AmbientColor = body_rep.DiffuseColor = [0.86, 0.86, 0.86]
    body_rep.EdgeColor = [0.6, 0.6, 0.6]
    line = Show(gamma, view)
    ColorBy(line, ("POINTS", "pressure"))
    line.LineWidth = 8.0
    # The line and the bodies lie in z = 0: lift the line towards the camera (no visible shift
    # in this parallel projection along z) so that no triangle hides part of it.
    line.Position = [0.0, 0.0, 1e-3]
    line.RescaleTransferFunctionToDataRange(False, True)
    scalar_bar(view, "pressure", "contact pressure (Pa)")
    axes(body_rep, view, zone)
    fit(view, zone)
    path = os.path.join(outdir, "results-contact-pressure.png")
    save(view, path)
    written.append(path)

    print("render_results: pictures:")
    for path in written:
        print(f"  {path}")


def check_on_interface(warped, gamma):
    """Print how far the warped Γc lies from the warped bodies' nearest points (should be 0:
    Γc's points are the nodes of its pairs' side, body 1's or under mortar the non-mortar
    body's, its displacement that body's there)."""
    bodies = servermanager.Fetch(warped)
    line = servermanager.Fetch(gamma)
    worst = 0.0
    for i in range(line.GetNumberOfPoints()):
        p = line.GetPoint(i)
        q = bodies.GetPoint(bodies.FindPoint(p))
        worst = max(worst, math.dist(p, q))
    print(f"render_results: the warped contact line's {line.GetNumberOfPoints()} points lie "
          f"within {worst:.3g} m of the warped bodies' points")


if __name__ == "__main__":
    main()
