#!/usr/bin/env pvpython
"""Standard views of a `flapstab cfd` run, rendered with ParaView's Python (pvpython).

    pvpython scripts/paraview_views.py RUN_DIR [-o OUT_DIR] [--time T] [--q Q]

RUN_DIR is the output directory of `flapstab cfd CASE -o RUN_DIR` (with fields/fields.xmf and
surfaces/surfaces.pvd). Writes three PNG images into OUT_DIR (default RUN_DIR/views):

  q_isosurface.png      iso-surface of the Q criterion at Q, coloured by speed, with the insect's surfaces
  surface_pressure.png  the insect's surfaces coloured by pressure (Pa)
  vorticity_slice.png   spanwise vorticity omega_y on the plane y = 0 (the symmetry plane), with the surfaces

Q defaults to (U_ref / L_ref)^2 from run.json (Q c^2 / U^2 = 1 with the mean wingtip speed U and the mean
chord c), the level commonly used for the leading-edge vortex. T defaults to the last output time. Axes are
flapstab's hover stability axes (x forward, y right, z down), so the camera looks from the insect's left side
with -z (up) pointing up on the image. Exit status 2 for a directory without the expected files.
"""
import argparse
import json
import os
import sys


def fail(message):
    sys.stderr.write("paraview_views.py: error: " + message + "\n")
    sys.exit(2)


def parse_arguments(argv):
    p = argparse.ArgumentParser(description="Render the standard views of a flapstab cfd run (pvpython).")
    p.add_argument("run_dir", help="output directory of `flapstab cfd` (fields/, surfaces/, run.json)")
    p.add_argument("-o", "--output", default=None, help="where to write the PNG images (default RUN_DIR/views)")
    p.add_argument("--time", type=float, default=None, help="output time to render, s (default: the last)")
    p.add_argument("--q", type=float, default=None, help="Q criterion level, 1/s^2 (default (U_ref/L_ref)^2)")
    p.add_argument("--size", type=int, nargs=2, default=[1600, 1000], metavar=("W", "H"), help="image size in pixels")
    return p.parse_args(argv)


def inputs(args):
    fields = os.path.join(args.run_dir, "fields", "fields.xmf")
    surfaces = os.path.join(args.run_dir, "surfaces", "surfaces.pvd")
    run_json = os.path.join(args.run_dir, "run.json")
    for path, what in ((fields, "the flow-field series (aero.cfd.fields_per_cycle > 0)"),
                       (surfaces, "the surface series (aero.cfd.surfaces_per_cycle > 0)")):
        if not os.path.isfile(path):
            fail("%s: missing (expected %s)" % (path, what))
    q = args.q
    if q is None:
        if not os.path.isfile(run_json):
            fail("%s: missing (expected run.json to take the default Q level; or give --q)" % run_json)
        with open(run_json) as f:
            flow = json.load(f).get("flow", {})
        try:
            q = (float(flow["u_ref_m_s"]) / float(flow["l_ref_m"])) ** 2
        except (KeyError, ValueError, ZeroDivisionError):
            fail("%s: key 'flow.u_ref_m_s' or 'flow.l_ref_m' missing (give --q)" % run_json)
    if not q > 0:
        fail("--q: %g is not positive (expected a Q level in 1/s^2)" % q)
    return fields, surfaces, q


def main(argv):
    args = parse_arguments(argv)
    fields_path, surfaces_path, q = inputs(args)
    out = args.output or os.path.join(args.run_dir, "views")
    os.makedirs(out, exist_ok=True)

    from paraview import simple as pv  # imported here so that --help works without ParaView

    reader = pv.OpenDataFile(fields_path)
    fields = reader
    with open(fields_path) as f:
        in_pieces = 'CollectionType="Spatial"' in f.read()
    if in_pieces:
        # Written per rank ([aero.cfd] field_files = "per-rank"): one block per rank. Merged into one grid (coincident
        # points merged), the cell-to-point averaging below sees both sides of a piece boundary, as in one file.
        fields = pv.MergeBlocks(Input=reader)
    surfaces = pv.PVDReader(FileName=surfaces_path)
    times = list(getattr(reader, "TimestepValues", []) or [])
    if not isinstance(times, list):
        times = [times]
    t = args.time if args.time is not None else (times[-1] if times else 0.0)

    view = pv.CreateView("RenderView")
    view.ViewSize = list(args.size)
    view.ViewTime = t
    view.Background = [1, 1, 1]
    view.OrientationAxesVisibility = 1

    def show_surfaces(colour_by_pressure):
        d = pv.Show(surfaces, view)
        if colour_by_pressure:
            pv.ColorBy(d, ("CELLS", "pressure"))
            d.RescaleTransferFunctionToDataRange(True, False)
            d.SetScalarBarVisibility(view, True)
        else:
            pv.ColorBy(d, None)
            d.DiffuseColor = [0.55, 0.55, 0.6]
        return d

    def camera_from_left():
        # Looking along +y (from the insect's left), up on the image = -z (up in stability axes).
        view.CameraPosition = [0, -1, 0]
        view.CameraFocalPoint = [0, 0, 0]
        view.CameraViewUp = [0, 0, -1]
        view.ResetCamera()

    def save(name):
        path = os.path.join(out, name)
        pv.SaveScreenshot(path, view, ImageResolution=list(args.size))
        print("wrote " + path)

    # 1. Q iso-surface coloured by speed.
    points = pv.CellDatatoPointData(Input=fields)
    contour = pv.Contour(Input=points, ContourBy=["POINTS", "q_criterion"], Isosurfaces=[q])
    contour.ComputeScalars = 1
    cd = pv.Show(contour, view)
    pv.ColorBy(cd, ("POINTS", "velocity", "Magnitude"))
    cd.RescaleTransferFunctionToDataRange(True, False)
    cd.SetScalarBarVisibility(view, True)
    sd = show_surfaces(False)
    view.CameraPosition = [1, -1, -0.6]
    view.CameraFocalPoint = [0, 0, 0]
    view.CameraViewUp = [0, 0, -1]
    view.ResetCamera()
    save("q_isosurface.png")
    pv.Hide(contour, view)
    pv.Hide(surfaces, view)

    # 2. Surfaces coloured by pressure.
    show_surfaces(True)
    view.CameraPosition = [0, 0, -1]  # from above
    view.CameraFocalPoint = [0, 0, 0]
    view.CameraViewUp = [1, 0, 0]
    view.ResetCamera()
    save("surface_pressure.png")
    pv.Hide(surfaces, view)

    # 3. Spanwise vorticity on the symmetry plane.
    sl = pv.Slice(Input=fields)
    sl.SliceType = "Plane"
    sl.SliceType.Origin = [0, 0, 0]
    sl.SliceType.Normal = [0, 1, 0]
    sd = pv.Show(sl, view)
    pv.ColorBy(sd, ("CELLS", "vorticity", "Y"))
    sd.RescaleTransferFunctionToDataRange(True, False)
    sd.SetScalarBarVisibility(view, True)
    show_surfaces(False)
    camera_from_left()
    save("vorticity_slice.png")
    del sd
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
