"""Render the element map of eta^FE (or another cell field) of an nndd result with ParaView.

    xvfb-run -a pvpython jobs/render_eta_fe.py PREFIX.xdmf OUT.png [--field eta_fe]
        [--title TEXT] [--label TEXT] [--undeformed] [--half-width 0.1] [--centre X Y]
        [--zoom-range window|global] [--preset Turbo] [--no-edges] [--no-domain]

Writes OUT.png, the contact zone (x in [-half-width, half-width] around x = 0 on the block's
top, with the mesh edges), and OUT-domain.png, both bodies whole (left out with --no-domain).
The bodies are shown in the deformed configuration (warped by the point field `displacement`,
at true scale: scale 1), unless --undeformed. The colour scale is logarithmic (eta per element
spans decades), its ends rounded out to round values; the contact-zone picture spans the values
inside its window unless --zoom-range global. Prints the fields found and the field's range per
body.
Opens PREFIX.xdmf (the bodies' time series) with ParaView's default reader (OpenDataFile: the
Xdmf3ReaderS of ParaView 5.11) at its last time step, the reported iterate; PREFIX-final.xdmf
(the same iterate, no time) works as well. Both bodies are one grid: a Threshold on the cell
field `body` (1 or 2) picks one where needed (the per-body ranges, the block's top at x = 0).
The path is made absolute: given a bare "hertz.xdmf" (no directory part), ParaView 5.11's Xdmf3
looks for "hertz.xdmfhertz.h5" and aborts.
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
    GetOpacityTransferFunction,
    GetScalarBar,
    OpenDataFile,
    Render,
    SaveScreenshot,
    SetActiveView,
    Show,
    Text,
    Threshold,
    WarpByVector,
)

RESOLUTION = [1600, 1000]
EDGE_COLOUR = [0.55, 0.55, 0.55]
# Colour-scale ends are rounded out to these mantissas, so that the end labels are round and
# do not crowd the ticks.
NICE = [1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 10.0]


def nice_range(lo, hi):
    """[lo, hi] widened to round values (mantissas in NICE), for a log colour scale."""
    e = math.floor(math.log10(lo))
    lo_n = max(m * 10 ** e for m in NICE if m * 10 ** e <= lo * (1 + 1e-12))
    e = math.floor(math.log10(hi))
    hi_n = min(m * 10 ** e for m in NICE if m * 10 ** e >= hi * (1 - 1e-12))
    return lo_n, hi_n


def fail(msg):
    sys.stderr.write(f"render_eta_fe: {msg}\n")
    sys.exit(1)


def parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("xdmf")
    p.add_argument("png")
    p.add_argument("--field", default="eta_fe", help="cell field to colour by (default eta_fe)")
    p.add_argument("--title", default=None, help="scalar bar title")
    p.add_argument("--label", default="", help="caption text, top left (e.g. the mesh level)")
    p.add_argument("--undeformed", action="store_true", help="do not warp by the displacement")
    p.add_argument("--half-width", type=float, default=0.1,
                   help="half-width (m) of the contact-zone view (default 0.1)")
    p.add_argument("--centre", type=float, nargs=2, default=None, metavar=("X", "Y"),
                   help="centre of the contact-zone view (default: x=0 on the block's top)")
    p.add_argument("--no-domain", action="store_true", help="skip the whole-domain picture")
    p.add_argument("--no-edges", action="store_true", help="no mesh edges in the contact zone")
    p.add_argument("--zoom-range", choices=["window", "global"], default="window",
                   help="colour range of the contact-zone picture: the values in its window "
                        "(default) or all the values, as in the whole-domain picture")
    p.add_argument("--preset", default="Turbo", help="ParaView colour map preset")
    return p.parse_args()


def body(source, k, time):
    """Body k (1 or 2) of the bodies grid: a Threshold on the cell field `body`, fetched at time."""
    part = Threshold(Input=source, Scalars=["CELLS", "body"])
    part.LowerThreshold = k - 0.5
    part.UpperThreshold = k + 0.5
    if hasattr(part, "ThresholdMethod"):  # ParaView 5.10+
        part.ThresholdMethod = "Between"
    part.UpdatePipeline(time)
    return servermanager.Fetch(part)


def array_names(attrs):
    return [attrs.GetArrayName(i) for i in range(attrs.GetNumberOfArrays())]


def field_stats(bodies, field):
    """Per body: (name, n cells, min, max, centre of the cell of the max, sum of squares)."""
    from vtkmodules.numpy_interface import dataset_adapter as dsa
    from vtkmodules.vtkFiltersCore import vtkCellCenters
    import numpy as np

    out = []
    for name, block in bodies:
        arr = block.GetCellData().GetArray(field)
        if arr is None or arr.GetNumberOfTuples() == 0:
            continue
        v = dsa.vtkDataArrayToVTKArray(arr)
        v = np.asarray(v, dtype=float)
        centres = vtkCellCenters()
        centres.SetInputData(block)
        centres.Update()
        pts = dsa.WrapDataObject(centres.GetOutput()).Points
        k = int(np.argmax(v))
        out.append((name, len(v), float(v.min()), float(v.max()),
                    (float(pts[k][0]), float(pts[k][1])), float((v * v).sum())))
    return out


def main():
    a = parse()
    xdmf = os.path.abspath(a.xdmf)
    if not os.path.isfile(xdmf):
        fail(f"no such file: {xdmf}")
    png = os.path.abspath(a.png)
    os.makedirs(os.path.dirname(png), exist_ok=True)

    reader = OpenDataFile(xdmf)  # ParaView's default reader for .xdmf (5.11: Xdmf3ReaderS)
    if reader is None:
        fail(f"ParaView found no reader for {xdmf}")
    # PREFIX.xdmf is a time series (times: NNDD iterations): show its last step, the reported
    # iterate. PREFIX-final.xdmf has no time.
    times = reader.TimestepValues
    times = [] if times is None else [times] if isinstance(times, (int, float)) else list(times)
    time = max(times) if times else 0.0
    if times:
        scene = GetAnimationScene()  # the views' time
        scene.UpdateAnimationUsingDataTimeSteps()
        scene.AnimationTime = time
    reader.UpdatePipeline(time)

    cell_fields = list(reader.CellData.keys())
    point_fields = list(reader.PointData.keys())
    step = f"time step {time:g} (last of {len(times)})" if times else "no time steps"
    print(f"render_eta_fe: {xdmf} ({reader.GetXMLName()}): {step}")
    print(f"render_eta_fe: cell fields: {', '.join(cell_fields)}")
    print(f"render_eta_fe: point fields: {', '.join(point_fields)}")
    if a.field not in cell_fields:
        hint = ""
        if a.field.startswith("eta"):
            hint = " (the estimates are written only when nndd runs with -nndd_estimate)"
        fail(f"cell field '{a.field}' not found in {xdmf}{hint}; "
             f"cell fields: {', '.join(cell_fields) or '(none)'}; "
             f"point fields: {', '.join(point_fields) or '(none)'}")
    if "body" not in cell_fields:
        fail(f"no cell field 'body' in {xdmf}: not an nndd bodies grid (PREFIX.xdmf or "
             f"PREFIX-final.xdmf)")

    bodies = [(f"body {k}", body(reader, k, time)) for k in (1, 2)]
    stats = field_stats(bodies, a.field)
    if not stats:
        fail(f"cell field '{a.field}' has no values at time {time:g} in {xdmf}")
    total = math.sqrt(sum(s[5] for s in stats))
    lo = min(s[2] for s in stats)
    hi = max(s[3] for s in stats)
    for name, n, vmin, vmax, (x, y), _ in stats:
        print(f"render_eta_fe: {name}: {n} cells, {a.field} in [{vmin:.4g}, {vmax:.4g}], "
              f"max at cell centre ({x:.4g}, {y:.4g})")
    print(f"render_eta_fe: {a.field}: range [{lo:.4g}, {hi:.4g}] "
          f"({math.log10(hi / lo) if lo > 0 else float('inf'):.2f} decades), "
          f"sqrt(sum of squares) {total:.6g}")

    source = reader
    deformed = not a.undeformed
    if deformed:
        if "displacement" not in point_fields:
            fail(f"no point field 'displacement' to deform by; point fields: "
                 f"{', '.join(point_fields)} (use --undeformed)")
        source = WarpByVector(Input=reader, Vectors=["POINTS", "displacement"], ScaleFactor=1.0)

    # The log scale needs a positive minimum: a zero-estimate cell would have none.
    lo_pos = lo
    if lo_pos <= 0.0:
        positives = [s[2] for s in stats if s[2] > 0]
        lo_pos = hi * 1e-6 if not positives else min(positives)
    lut_lo, lut_hi = nice_range(lo_pos, hi)

    title = a.title or (r"$\eta^{\mathrm{FE}}$ per element" if a.field == "eta_fe"
                        else f"{a.field} per element")
    config = "deformed (true scale)" if deformed else "undeformed"

    # The plot area in pixels (left, right, bottom, top from the bottom edge): room is left for
    # the y labels on the left, the scalar bar on the right and the caption on top.
    plot = (150, 1290, 95, 900)

    def view_with(shown, caption, edges, lut_lo, lut_hi):
        view = CreateView("RenderView")
        SetActiveView(view)
        view.ViewSize = RESOLUTION
        view.Background = [1.0, 1.0, 1.0]
        # ParaView 5.10+ takes the background from the colour palette unless told not to.
        if hasattr(view, "UseColorPaletteForBackground"):
            view.UseColorPaletteForBackground = 0
        view.OrientationAxesVisibility = 0
        view.CameraParallelProjection = 1
        view.InteractionMode = "2D"
        view.UseFXAA = 0  # flat cells with sharp edges: FXAA only blurs them and grows the PNG

        rep = Show(shown, view)
        Render(view)  # the first render resets the camera: do it before we place ours
        if edges:
            rep.SetRepresentationType("Surface With Edges")
            rep.EdgeColor = EDGE_COLOUR
            rep.LineWidth = 1.0
        else:
            rep.SetRepresentationType("Surface")
        ColorBy(rep, ("CELLS", a.field))
        lut = GetColorTransferFunction(a.field)
        lut.ApplyPreset(a.preset, True)
        lut.AutomaticRescaleRangeMode = "Never"
        lut.RescaleTransferFunction(lut_lo, lut_hi)
        lut.UseLogScale = 1
        GetOpacityTransferFunction(a.field).RescaleTransferFunction(lut_lo, lut_hi)

        bar = GetScalarBar(lut, view)
        bar.Title = title
        bar.ComponentTitle = ""
        bar.Visibility = 1
        bar.Orientation = "Vertical"
        bar.WindowLocation = "Any Location"
        bar.Position = [0.89, 0.12]
        bar.ScalarBarLength = 0.76
        bar.ScalarBarThickness = 24
        bar.TitleColor = [0, 0, 0]
        bar.LabelColor = [0, 0, 0]
        bar.TitleFontSize = 24
        bar.LabelFontSize = 20
        bar.TitleFontFamily = "Arial"
        bar.LabelFontFamily = "Arial"
        bar.AddRangeLabels = 1
        bar.RangeLabelFormat = "%.2g"
        bar.LabelFormat = "%.2g"
        bar.DrawTickMarks = 1
        bar.TextPosition = "Ticks left/bottom, annotations right/top"

        text = Text(Text=caption)
        trep = Show(text, view)
        trep.Color = [0, 0, 0]
        trep.FontSize = 22
        trep.WindowLocation = "Upper Left Corner"
        return view, rep

    def axes(rep, view, xlim, ylim):
        """A labelled coordinate grid (metres) around the visible window."""
        g = rep.DataAxesGrid
        g.GridAxesVisibility = 1
        g.XTitle = "x (m)"
        g.YTitle = ""  # drawn over the labels in 2D: a text above the axis instead
        g.ZTitle = ""
        for attr in ("XTitleColor", "YTitleColor", "XLabelColor", "YLabelColor", "GridColor"):
            setattr(g, attr, [0, 0, 0])
        g.XTitleFontSize = g.YTitleFontSize = 20
        g.XLabelFontSize = g.YLabelFontSize = 18
        g.ShowGrid = 0
        g.UseCustomBounds = 1
        g.CustomBounds = [xlim[0], xlim[1], ylim[0], ylim[1], 0.0, 0.0]
        g.FacesToRender = 0x04 | 0x20  # the xy faces (min-Z and max-Z coincide here)
        g.AxesToLabel = 0x01 | 0x02    # min-X and min-Y edges
        ytitle = Text(Text="y (m)")
        yrep = Show(ytitle, view)
        yrep.Color = [0, 0, 0]
        yrep.FontSize = 20
        yrep.WindowLocation = "Any Location"
        yrep.Position = [(plot[0] - 95) / RESOLUTION[0], (plot[3] + 12) / RESOLUTION[1]]

    def frame(view, xlim, ylim):
        """Fit the window x in xlim, y in ylim into the plot area (parallel projection)."""
        per_px = max((xlim[1] - xlim[0]) / (plot[1] - plot[0]),
                     (ylim[1] - ylim[0]) / (plot[3] - plot[2]))
        cx, cy = 0.5 * (xlim[0] + xlim[1]), 0.5 * (ylim[0] + ylim[1])
        # The camera looks at the view's centre; the plot area's centre is off it.
        fx = cx + (0.5 * RESOLUTION[0] - 0.5 * (plot[0] + plot[1])) * per_px
        fy = cy + (0.5 * RESOLUTION[1] - 0.5 * (plot[2] + plot[3])) * per_px
        view.CameraPosition = [fx, fy, 10.0]
        view.CameraFocalPoint = [fx, fy, 0.0]
        view.CameraViewUp = [0.0, 1.0, 0.0]
        view.CameraParallelScale = 0.5 * RESOLUTION[1] * per_px

    name = r"$\eta^{\mathrm{FE}}$" if a.field == "eta_fe" else a.field
    label = (a.label + ": " if a.label else "") + f"{name} per element, {config}"

    # 1. The contact zone.
    if a.centre is not None:
        cx, cy = a.centre
    else:
        cx, cy = 0.0, 0.0
        if deformed:
            # The block's top at x = 0 moves down by the contact displacement: follow it.
            cy = contact_drop(bodies[0][1])
    w = a.half_width
    h = w * (plot[3] - plot[2]) / (plot[1] - plot[0])
    xlim, ylim = (cx - w, cx + w), (cy - h, cy + h)
    # Cut the bodies to the window, so that the picture ends where the axes do.
    window = Clip(Input=source)
    window.ClipType = "Box"
    window.ClipType.Position = [xlim[0], ylim[0], -1.0]
    window.ClipType.Length = [xlim[1] - xlim[0], ylim[1] - ylim[0], 2.0]
    window.Invert = 1  # keep the inside
    window.Exact = 1   # cut at the box's faces exactly, not along whole cells
    window.UpdatePipeline(time)
    inside = window.CellData[a.field].GetRange() if a.field in window.CellData.keys() else None
    if inside:
        print(f"render_eta_fe: contact-zone window x in [{xlim[0]:.3g}, {xlim[1]:.3g}], "
              f"y in [{ylim[0]:.3g}, {ylim[1]:.3g}]: {a.field} in "
              f"[{inside[0]:.4g}, {inside[1]:.4g}]")
    zlo, zhi = (lut_lo, lut_hi)
    if a.zoom_range == "window" and inside and inside[0] > 0:
        zlo, zhi = nice_range(*inside)
    view, rep = view_with(window, label + ", contact zone", not a.no_edges, zlo, zhi)
    axes(rep, view, xlim, ylim)
    frame(view, xlim, ylim)
    Render(view)
    SaveScreenshot(png, view, ImageResolution=RESOLUTION, CompressionLevel="9")
    print(f"render_eta_fe: wrote {png}")

    # 2. Both bodies whole.
    if not a.no_domain:
        root, ext = os.path.splitext(png)
        png2 = f"{root}-domain{ext}"
        bounds = source.GetDataInformation().GetBounds()
        xlim, ylim = (bounds[0], bounds[1]), (bounds[2], bounds[3])
        view, rep = view_with(source, label, False, lut_lo, lut_hi)
        axes(rep, view, xlim, ylim)
        frame(view, xlim, ylim)
        Render(view)
        SaveScreenshot(png2, view, ImageResolution=RESOLUTION, CompressionLevel="9")
        print(f"render_eta_fe: wrote {png2}")


def contact_drop(block):
    """The vertical displacement of body 1's point nearest (0, 0), or 0 without one. (Body 2
    has a point at (0, 0) too: the cylinder touches the block there.)"""
    disp = block.GetPointData().GetArray("displacement")
    if disp is None or block.GetNumberOfPoints() == 0:
        return 0.0
    k = block.FindPoint(0.0, 0.0, 0.0)
    if k < 0:
        return 0.0
    return float(disp.GetTuple(k)[1])


if __name__ == "__main__":
    main()
