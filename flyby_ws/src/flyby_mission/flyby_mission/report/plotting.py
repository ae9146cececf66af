"""Drawing shared by the report library (flyby_mission.report) and the figure scripts (plan_capture.py,
compare_methods.py, the benchmarks).

Matplotlib with the Agg backend: the figures are files and need no display. Positions are hill
positions [m] (flyby_sim.dynamics.orbital: x along-track, y orbit anti-normal, z toward Earth), one
point per row (N, 3). The scripts draw them through a projection, points (N, 3) -> plot coordinates:
``xz`` for the hill x-z plane, ``cube_clip(half_width_m)`` for 3-D axes about the target.
"""

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402
from scipy.spatial import ConvexHull  # noqa: E402

HILL_AXIS_LABELS = ('hill x [m]', 'hill y [m]', 'hill z, toward Earth [m]')


def save(fig, path, dpi):
    """Write the figure to path and close it."""
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def xz(points):
    """The projection on the hill x-z plane: (x, z) of points (N, 3)."""
    points = np.asarray(points)
    return points[:, 0], points[:, 2]


def cube_clip(half_width_m):
    """The projection for 3-D axes showing |x|, |y|, |z| <= half_width_m: points (N, 3) -> (3, N), with
    NaN for the points outside (3-D axes do not clip)."""
    def project(points):
        p = np.array(points, dtype=float)
        p[np.any(np.abs(p) > half_width_m, axis=1)] = np.nan
        return p.T
    return project


def cube_axes(ax, half_width_m, n_ticks, labels=HILL_AXIS_LABELS, **props):
    """Set 3-D axes to the cube |x|, |y|, |z| <= half_width_m [m], hill z drawn downward (up = away
    from Earth), n_ticks ticks per axis; props are further Axes properties (title)."""
    ticks = np.linspace(-half_width_m, half_width_m, n_ticks)
    ax.set(xlim=(-half_width_m, half_width_m), ylim=(-half_width_m, half_width_m),
           zlim=(half_width_m, -half_width_m), xticks=ticks, yticks=ticks, zticks=ticks,
           xlabel=labels[0], ylabel=labels[1], zlabel=labels[2], **props)


def plot_path(ax, points, project, **style):
    """A line through the points (N, 3), drawn through project; none (no legend entry) when all of
    them are outside the axes."""
    coords = project(points)
    if not np.isnan(coords[0]).all():
        ax.plot(*coords, **style)


def mark_points(ax, marks, project, **style):
    """One marker per (label, position (3,), own style) of marks, drawn through project with style
    updated by its own. A point outside the axes is left out; a label repeated is shown once in the
    legend."""
    seen = set()
    for label, position, own in marks:
        coords = project(np.asarray(position)[None, :])
        if np.isnan(coords[0]).all():
            continue
        ax.plot(*coords, ls='none', label=None if label in seen else label, **{**style, **own})
        seen.add(label)


def cylinder_surfaces(region, axis_hill, samples=64):
    """Per cylinder of a keep-out region (flyby_planner.flyby.keepout.SweptRegion) about its unit hill axis:
    the closed surface as a (4, samples, 3) grid [m] (bottom centre, bottom rim, top rim, top centre)."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis_hill)))]
    u = np.cross(axis_hill, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis_hill, u)
    phi = np.linspace(0.0, 2.0 * np.pi, samples)
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    centre = np.zeros_like(ring)
    return [np.stack((lo * axis_hill + centre, lo * axis_hill + r * ring, hi * axis_hill + r * ring,
                      hi * axis_hill + centre))
            for lo, hi, r in zip(region.axial_min_m, region.axial_max_m, region.radius_m, strict=True)]


def fill_outline_xz(ax, point_sets, **style):
    """Fill the outline (convex hull) in the x-z plane of each point set (..., 3); label only the first."""
    for points in point_sets:
        x_z = points.reshape(-1, 3)[:, [0, 2]]
        hull = x_z[ConvexHull(x_z, qhull_options='QJ').vertices]  # QJ: a flat outline does not fail
        ax.fill(hull[:, 0], hull[:, 1], **style)
        style.pop('label', None)


def sphere_xz(ax, radius_m, **style):
    """The outline of the sphere of radius_m [m] about the target's centre of mass in the x-z plane."""
    ax.add_patch(Circle((0.0, 0.0), radius_m, fill=False, **style))


def sphere_wireframe(ax, radius_m, n_lon, n_lat, **style):
    """The sphere of radius_m [m] about the target's centre of mass as a 3-D wireframe of n_lon
    longitudes by n_lat latitudes."""
    lon, lat = np.meshgrid(np.linspace(0.0, 2.0 * np.pi, n_lon), np.linspace(0.0, np.pi, n_lat))
    ax.plot_wireframe(radius_m * np.cos(lon) * np.sin(lat), radius_m * np.sin(lon) * np.sin(lat),
                      radius_m * np.cos(lat), **style)
