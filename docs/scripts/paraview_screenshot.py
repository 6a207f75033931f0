"""A ParaView screenshot of a run's `results.exo`, for docs/output.md (not run by CI).

    apt-get install paraview python3-paraview xvfb          # Debian's ParaView 5.11
    mbdc run models/plate_hole.mbd --interp --format exodus -o out/plate_hole
    xvfb-run -a pvbatch docs/scripts/paraview_screenshot.py out/plate_hole/results.exo \
        von_mises docs/images/paraview_plate_hole.png

ParaView's own Exodus II reader opens the file (no converter, no plugin), shows its last
time step warped by the displacement it applies by default, coloured by an element
variable, and saves the view.
"""

import sys

from paraview.simple import (ColorBy, ExodusIIReader, GetActiveViewOrCreate, GetAnimationScene,
                             GetDisplayProperties, ResetCamera, SaveScreenshot, Show,
                             UpdatePipeline)

path, variable, png = sys.argv[1], sys.argv[2], sys.argv[3]
reader = ExodusIIReader(FileName=[path])
reader.ElementVariables = [variable]
reader.ApplyDisplacements = 1
scene = GetAnimationScene()
scene.UpdateAnimationUsingDataTimeSteps()
times = reader.TimestepValues
last = times[-1] if hasattr(times, "__len__") and len(times) else times
UpdatePipeline(time=last, proxy=reader)
view = GetActiveViewOrCreate("RenderView")
view.ViewSize = [1200, 700]
view.ViewTime = last
view.OrientationAxesVisibility = 1
display = Show(reader, view)
ColorBy(display, ("CELLS", variable))
display.RescaleTransferFunctionToDataRange(True, False)
display.SetScalarBarVisibility(view, True)
ResetCamera(view)
SaveScreenshot(png, view, ImageResolution=[1200, 700])
print(f"{path}: {len(times) if hasattr(times, '__len__') else 1} time steps; "
      f"wrote {png} at t = {last}")
