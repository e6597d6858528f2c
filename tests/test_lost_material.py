"""Material thinner than h: the mesh says where it left material out (issue 12, thin walls)."""

import re
import warnings

import numpy as np
import pytest

import fepre
from fepre import sdf
from fepre.distmesh import added_material, lost_material

PLATE_VOLUME = 20 * 20 * 4


def finned_plate(thickness: float):
    """A 20 x 20 x 4 plate with a fin ``thickness`` thick and 8 high standing on it at x = 5."""
    return sdf.box((20, 20, 4)) | sdf.box((thickness, 20, 10)).translate((5, 0, 5))


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_a_fin_thinner_than_h_is_named_with_its_thickness_place_and_the_h_that_keeps_it():
    """Before: a 0.6 thick fin at h = 1 lost 12% of its volume without a word (a 0.5 fin, here,
    loses 7%; the 0.6 fin is now kept whole by the Qhull fallback of the final triangulation)."""
    part = finned_plate(0.5)
    with pytest.warns(fepre.ResolutionWarning, match=r"0\.5 thick.*h <= 0\.25") as caught:
        mesh = fepre.distmesh(part, 1.0)
    missing = PLATE_VOLUME + 0.5 * 20 * 8 - mesh.volume
    assert missing > 3.0  # the loss is real
    regions = lost_material(part, mesh.points, mesh.cells_dict[10], 1.0)
    assert regions[0].thickness == pytest.approx(0.5, abs=0.05)
    assert regions[0].center[0] == pytest.approx(5.0, abs=0.3)
    assert 2.0 < regions[0].center[2] < 10.0
    # the estimate is of the right size (grid nodes at h/4 around a 0.5 wide sliver of fin)
    assert 0.5 * missing < sum(r.volume for r in regions) < 2.0 * missing
    assert float(mesh.field_data["distmesh_lost_volume"][0]) == pytest.approx(sum(r.volume for r in regions))
    assert [str(w.message) for w in caught if "leaves out" in str(w.message)]


def test_a_fin_thinner_than_the_sampling_grid_has_its_own_thickness():
    """At h = 2.4 the grid (h / 4 = 0.6) misses the middle of a 0.5 fin: twice the deepest
    sample's depth said 0.1 (a trial's 0.8 rib was "0.162 thick" and h <= 0.081 was advised).
    The mesh is the plate alone, cut into six cells."""
    corners = np.array([[x, y, z] for z in (-2, 2) for y in (-10, 10) for x in (-10, 10)], float)
    tets = np.array([[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]])
    regions = lost_material(finned_plate(0.5), corners, tets, 2.4)
    assert len(regions) == 1 and regions[0].thickness == pytest.approx(0.5, abs=0.01)
    assert regions[0].volume == pytest.approx(0.5 * 20 * 8, rel=0.15)


def test_a_fin_meshed_at_the_suggested_h_keeps_its_volume_without_a_warning():
    """Half the fin's thickness: two elements across (at one, its base corners were cut)."""
    part = sdf.box((4, 4, 1)) | sdf.box((0.5, 4, 2)).translate((0.5, 0, 1.5))
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ResolutionWarning)
        mesh = fepre.distmesh(part, 0.25)
    assert mesh.volume == pytest.approx(16 + 0.5 * 4 * 2, rel=5e-3)


@pytest.mark.parametrize(
    "part, h",
    [
        (finned_plate(3.0), 1.0),
        (sdf.sphere(5.0), 1.0),
        (sdf.cylinder(1.5, 10.0), 1.0),  # a pin 3 h across: convex chords are not "lost"
        (sdf.torus(5.0, 1.2), 0.8),
        (sdf.box((10, 10, 10)) - sdf.cylinder(2.0, 12.0), 1.0),
    ],
)
def test_parts_that_h_resolves_raise_no_resolution_warning(part, h):
    # nothing is lost or added; a curved part's chords may leave its volume short (a sphere of
    # radius 5 h by about 3 h^2 / 8 r^2 = 1.5%), which the volume check names, with its figures
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(part, h)
    lines = [str(w.message) for w in caught if issubclass(w.category, fepre.ResolutionWarning)]
    assert all("the mesh's volume is" in line and "short of the model's" in line for line in lines), lines
    assert float(mesh.field_data["distmesh_lost_volume"][0]) == 0.0
    assert float(mesh.field_data["distmesh_added_volume"][0]) == 0.0


def test_a_mesh_that_covers_the_model_has_no_lost_region():
    """An independent mesh (a box cut into six tetrahedra) covers its own box exactly."""
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
    tets = np.array([[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]])
    assert lost_material(sdf.box((2, 2, 2)), corners, tets, 1.0) == []
    # half the box missing: one region, about 4 in volume; the chord through its deepest node
    # (0.75 deep on the grid of h/4, off the covered diagonal) is the box's 2
    half = lost_material(sdf.box((2, 2, 2)), corners, tets[:3], 1.0)
    assert len(half) == 1
    assert half[0].thickness == pytest.approx(2.0, abs=0.01)
    assert half[0].volume == pytest.approx(4.0, rel=0.35)


def test_a_slot_narrower_than_h_that_the_mesh_bridges_is_named():
    """A 0.4 wide slot at h = 1 was filled with 2.2 of material without a word."""
    slotted = sdf.box((8, 4, 4)) - sdf.box((0.4, 6, 3), center=(0, 0, 1))
    with pytest.warns(fepre.ResolutionWarning, match=r"adds about .* a gap 0\.4 wide.*h <= 0\.2"):
        mesh = fepre.distmesh(slotted, 1.0)
    added = mesh.volume - (128 - 0.4 * 4 * 2.5)
    assert added > 1.0
    regions = added_material(slotted, mesh.points, mesh.cells_dict[10], 1.0)
    assert regions[0].thickness == pytest.approx(0.4, abs=0.02)
    assert abs(regions[0].center[0]) < 0.1 and regions[0].center[2] > -0.5
    assert 0.5 * added < sum(r.volume for r in regions) < 2.5 * added
    assert float(mesh.field_data["distmesh_added_volume"][0]) == pytest.approx(sum(r.volume for r in regions))


def test_a_groove_closing_to_an_edge_is_named_without_an_h_that_cannot_open_it():
    """A V-groove's bottom is narrower than any element: a new user's angle_block.STL was told
    "h <= 0.02" at D/25 and, meshed at 0.02, "h <= 0.0059". The walls' angle names it."""
    half = np.radians(10.0)  # walls at 20 degrees, the groove's edge 1.5 under the top face
    groove = (sdf.plane((np.cos(half), 0, -np.sin(half)), (0, 0, 0.5))
              & sdf.plane((-np.cos(half), 0, -np.sin(half)), (0, 0, 0.5)))
    part = sdf.box((8, 12, 4)) - groove
    with pytest.warns(fepre.ResolutionWarning, match=r"adds about .* a groove [\d.]+ wide there, its walls at 20 deg "
                      r"closing to an edge; a groove or corner that closes to an edge is filled") as caught:
        mesh = fepre.distmesh(part, 1.0)
    assert not any("h <=" in str(w.message) for w in caught if "adds about" in str(w.message))
    (region,) = added_material(part, mesh.points, mesh.cells_dict[10], 1.0)
    assert region.opening == pytest.approx(20.0, abs=1.0)
    assert abs(region.center[0]) < 0.05 and 0.5 < region.center[2] < 2.0
    # its width where filled is the groove's at that height: 2 (z - 0.5) tan 10 deg
    assert region.thickness < 1.0


def test_the_walls_of_a_gap_are_measured_across_it():
    from fepre.distmesh.lost_material import gap_opening

    slot = sdf.box((8, 4, 4)) - sdf.box((0.4, 6, 3), center=(0, 0, 1))
    c, s = np.cos(np.radians(20.0)), np.sin(np.radians(20.0))  # walls at 40 degrees
    wedge = sdf.box((8, 4, 4)) - (sdf.plane((c, 0, -s), (0, 0, 0)) & sdf.plane((-c, 0, -s), (0, 0, 0)))
    corner = sdf.box((4, 4, 4)) | sdf.box((4, 4, 4), center=(4, 0, -4))  # a re-entrant edge at (2, y, -2)
    assert gap_opening(slot, np.array([[0.1, 0.0, 1.0]]), 1.0) == pytest.approx([0.0], abs=0.5)
    assert gap_opening(wedge, np.array([[0.1, 0.0, 1.0]]), 1.0) == pytest.approx([40.0], abs=0.5)
    assert gap_opening(corner, np.array([[2.3, 0.0, -2.1]]), 1.0) == pytest.approx([180.0])


def test_parts_touching_along_an_edge_are_joined_with_a_warning():
    """Two boxes sharing only an edge: a conforming mesh must either join them or cut them apart
    there; DistMesh joins them (+1.3% volume, one component) and now says so."""
    pair = sdf.box((4, 4, 4)) | sdf.box((4, 4, 4), center=(4, 4, 0))
    with pytest.warns(fepre.ResolutionWarning, match="adds about"):
        mesh = fepre.distmesh(pair, 0.5)
    regions = added_material(pair, mesh.points, mesh.cells_dict[10], 0.5)
    assert len(regions) == 1
    assert regions[0].center[:2] == pytest.approx((2.0, 2.0), abs=0.1)  # on the shared edge


@pytest.mark.parametrize("width", [0.8, 1.2])
def test_slots_that_h_resolves_stay_open_without_a_warning(width):
    slotted = sdf.box((8, 4, 4)) - sdf.box((width, 6, 3), center=(0, 0, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ResolutionWarning)
        mesh = fepre.distmesh(slotted, 1.0)
    assert mesh.volume == pytest.approx(128 - width * 4 * 2.5, rel=1e-6)
    assert float(mesh.field_data["distmesh_added_volume"][0]) == 0.0


def _faceted_rod():
    """A rod 2 long and 0.24 across as 16 flat facets: at h = D/25 (0.081) a limb 3 h across,
    not thinner than h, which loses 5% of its section to its chords."""
    import pyvista as pv

    return sdf.mesh(pv.Cylinder(radius=0.12, height=2.0, resolution=16, capping=True).triangulate().clean())


def _volume_warning(model, h):
    import re

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(model, h)
    lines = [str(w.message) for w in caught if issubclass(w.category, fepre.ResolutionWarning) and "volume is" in str(w.message)]
    named = [float(re.search(r"mesh with h <= ([0-9.e-]+) to come within", line).group(1)) for line in lines]
    return mesh, lines, named


def test_a_triangle_mesh_model_meshed_short_of_its_volume_warns_with_the_h_that_keeps_it():
    """Issue 32: fertility at D/25 came out 3.7% short, arm 8.8%, with no warning naming an h
    (nothing there is thinner than h). The mesh's volume is now checked against the model's
    exact one and the warning names the h that brings it to about 0.5% (taking the error to fall
    as h^1.5: a new user's quadknot fell as h^1.2, and the square law's h left it at 1.09%)."""
    model = _faceted_rod()
    h = float(np.linalg.norm(np.subtract(*model.bounds[::-1]))) / 25
    mesh, lines, named = _volume_warning(model, h)
    error = mesh.volume / model.volume - 1
    assert -0.08 < error < -0.01  # measured -5.3%
    assert len(lines) == 1 and f"{100 * abs(error):.1f}% short of the model's" in lines[0]
    assert named[0] == pytest.approx(h * (0.005 / abs(error)) ** (1 / 1.5), rel=0.03)  # two digits


def test_the_volume_warning_holds_far_from_the_origin_and_through_transforms():
    """A part far from the origin is meshed as its translation, which hid the triangle-mesh
    model from the check (a pulley STL at 1e4 came out 1.7% over with no warning); a scaled
    model's exact volume is the model's times the scale cubed."""
    import pyvista as pv

    rod = pv.Cylinder(radius=0.12, height=2.0, resolution=16, capping=True).triangulate().clean()
    rod.points = rod.points.astype(np.float64)  # float32 at 1e4 would move the facets
    far = sdf.mesh(rod.translate((1e4, -1e4, 1e4)))
    h = float(np.linalg.norm(np.subtract(*far.bounds[::-1]))) / 25
    mesh, lines, named = _volume_warning(far, h)
    error = mesh.volume / far.volume - 1
    assert len(lines) == 1 and f"{100 * abs(error):.1f}% short of the model's" in lines[0]
    near = sdf.mesh(rod)
    assert far.volume == pytest.approx(near.volume, rel=1e-9)
    mesh, lines, _ = _volume_warning(near.scale(2.0), 2 * h)
    assert len(lines) == 1 and f"{mesh.volume:.4g} against {8 * near.volume:.4g}" in lines[0]


@pytest.mark.slow  # about 10 s
def test_the_h_named_for_the_volume_keeps_it():
    """At the h named the volume is within 1% and nothing warns."""
    model = _faceted_rod()
    h = float(np.linalg.norm(np.subtract(*model.bounds[::-1]))) / 25
    _, _, named = _volume_warning(model, h)
    mesh, lines, _ = _volume_warning(model, named[0])
    assert lines == []
    assert mesh.volume == pytest.approx(model.volume, rel=0.01)  # measured -0.42%


def _lattice_mesh(extent: float, spacing: float):
    """A Delaunay mesh of a cubic lattice filling the box ``[-extent, extent]^3``, its inner
    nodes jittered (a mesh's nodes are not on the checks' grid)."""
    from scipy.spatial import Delaunay

    axis = np.arange(-extent, extent + 1e-9, spacing)
    points = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    inner = np.all(np.abs(points) < extent - 1e-9, axis=1)
    points[inner] += np.random.default_rng(1).uniform(-0.2, 0.2, (int(inner.sum()), 3)) * spacing
    return points, Delaunay(points).simplices.astype(np.int64)


def test_a_graded_meshs_checks_sample_each_zone_at_its_octave_and_still_find_what_one_fine_grid_finds():
    """Issue 33: a graded mesh's checks sample each zone at a quarter of its sizes' octave (a
    size of 1 at x = -10 growing to 7 at x = 10: three octaves), not the whole box at h / 4.
    Cubes of 3 (the cells whose centroids are in them, about 14 of volume) left out in the
    finest zone and in the coarsest (half the size there: the count of deep nodes a region
    needs is a volume, 8 nodes at h / 4, one at least on a coarser grid), and a slot 2.4 wide
    the cells bridge in the coarsest, are found where and about as large as one fine grid finds
    them; a mesh that covers the model has no region either way."""
    from fepre.distmesh.check_zones import check_zones
    from fepre.distmesh.lost_material import _box, material_checks

    h = 1.0
    size = lambda p: h + 0.3 * np.abs(p[:, 0] + 10.0)  # noqa: E731
    box = sdf.box(20.0)
    points, tets = _lattice_mesh(10.0, 1.0)
    zones = check_zones(size, h, 0.25 * h, *_box(box, points, h))
    assert zones is not None and zones.levels.min() == 0 and zones.levels.max() == 2
    assert zones.level_at(np.array([[-8.0, 0, 0], [8.0, 0, 0]])).tolist() == [0, 2]
    assert material_checks(box, points, tets, h, size) == ([], [])
    centroids = points[tets].mean(axis=1)
    holes = [np.all(np.abs(centroids - c) < 1.5, axis=1) for c in ((-7.5, 0.0, 0.0), (6.5, 0.0, 0.0))]
    kept = tets[~(holes[0] | holes[1])]
    graded, _ = material_checks(box, points, kept, h, size)
    fine, _ = material_checks(box, points, kept, h, None)
    assert len(graded) == len(fine) == 2
    for ours, theirs in zip(sorted(graded, key=lambda r: r.center), sorted(fine, key=lambda r: r.center)):
        assert np.allclose(ours.center, theirs.center, atol=0.6)
        assert ours.volume == pytest.approx(theirs.volume, rel=0.5) and theirs.volume > 10.0
    slotted = box - sdf.box((2.4, 30.0, 30.0), center=(7.0, 0.0, 0.0))  # deeper than 0.15 of the size 6 there
    (_, added), (_, fine) = material_checks(slotted, points, tets, h, size), material_checks(slotted, points, tets, h, None)
    assert len(added) == len(fine) == 1 and added[0].center[0] == pytest.approx(7.0, abs=0.3)
    assert added[0].thickness == pytest.approx(2.4, abs=0.3) and added[0].volume == pytest.approx(fine[0].volume, rel=0.2)


def test_gaps_narrower_than_the_sampling_grid_are_found_and_named_when_the_mesh_is_refused():
    """Five plates 0.5 apart at h = 1.2: the mesh fills the gaps (+36%) and is refused. The grid
    of h / 4 had no node deeper than 0.1 in any gap (below the 0.15 h test), so no gap was found
    and the refusal spoke of parts thinner than h only. The width is twice the deepest node's
    depth, 0.2 (the advice, h <= 0.1, keeps the gaps open)."""
    plates = sdf.union(*[sdf.box((6, 6, 1.0), center=(0, 0, 1.5 * i)) for i in range(5)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(fepre.MeshingError, match=r"\+3\d% off.*the mesh adds about .* a gap 0\.2 wide.*h <= 0\.1"):
            fepre.distmesh(plates, 1.2)


def _bracket():
    """A plate with a boss, a 2.5 thick rib and two holes (genus 2), as a new user's CAD bracket."""
    plate = sdf.box((100, 60, 10), center=(50, 30, 5))
    boss = sdf.cylinder(12, 20, center=(30, 30, 20))
    rib = sdf.box((40, 2.5, 15), center=(70, 30, 17.5))
    return (plate | boss | rib) - sdf.cylinder(5, 32, center=(30, 30, 15)) - sdf.cylinder(4, 12, center=(80, 12, 5))


def test_the_genus_of_surfaces_and_models():
    import pyvista as pv

    from fepre.distmesh.genus import model_genus, surface_genus
    from fepre.distmesh.lost_material import _sampled

    torus = pv.ParametricTorus(ringradius=1.0, crosssectionradius=0.3).triangulate().clean()
    two = torus.merge(torus.translate((5, 0, 0)))
    assert surface_genus(torus.regular_faces) == 1 and surface_genus(two.regular_faces) == 2
    assert surface_genus(torus.regular_faces[1:]) is None  # open
    assert model_genus(sdf.mesh(torus).translate((1e4, 0, 0)), None) == 1  # its own triangles, through a move
    points = np.array([[-2.0, -2, -1], [2, 2, 1]])
    assert model_genus(_bracket(), None) is None  # no grid, no triangles
    grid = _sampled(sdf.torus(1.0, 0.3), points, np.zeros((0, 4), int), 0.2)
    assert model_genus(sdf.torus(1.0, 0.3), grid) == 1


def test_a_change_of_genus_is_named_only_with_the_regions_that_made_it():
    """camelhead.off's zero set on the grid of h / 4 had genus 9 (perforated where the head is a
    sheet that thin), its mesh 0, and only a lost wall was found: the warning said "a hole or a
    gap ... bridged". A genus lower than the model's needs added regions, a higher one lost."""
    import pyvista as pv

    from fepre.distmesh.genus import genus_change
    from fepre.distmesh.lost_material import LostRegion

    torus = pv.ParametricTorus(ringradius=1.0, crosssectionradius=0.3).triangulate().clean()
    ball = pv.Sphere().regular_faces  # genus 0 against the torus's 1
    model = sdf.mesh(torus)
    region = [LostRegion((1.0, 0.0, 0.0), 0.1, 0.01)]
    assert genus_change(ball, model, None, region, []) is None  # lost only: no hole bridged
    message = genus_change(ball, model, None, [], region)
    assert message.startswith("the mesh's surface has genus 0 where the model's has 1 (a hole or a gap")
    two = torus.merge(torus.translate((5, 0, 0))).regular_faces  # genus 2 against 1
    assert genus_change(two, model, None, [], region) is None  # added only: no wall punched
    assert "genus 2 where the model's has 1 (a wall" in genus_change(two, model, None, region, [])


def test_a_wall_lost_over_the_volume_floor_that_opens_a_hole_is_named_by_the_genus_too():
    """A new user's hollow shaft at D/25: its keyway's floor was lost and the keyway opened into
    the bore, named by its volume only ("leaves out about ..."). The genus is now compared
    wherever regions are found: here a keyway down to a floor 0.3 thick in a tube."""
    tube = sdf.cylinder(3.0, 8.0) - sdf.cylinder(2.0, 10.0)
    part = tube - sdf.box((1.2, 4.0, 5.0), center=(0.0, 4.3, 0.0))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fepre.distmesh(part, 0.8)
    messages = [str(w.message) for w in caught]
    assert any(re.search(r"leaves out about .*, 0\.3 thick", m) for m in messages)
    assert "distmesh: the mesh's surface has genus 2 where the model's has 1 (a wall thinner than the mesh resolves " \
           "punched through, or a hole's rim cut), at the places named above" in messages


@pytest.mark.parametrize("h, punched", [(4.8168, True), (4.4, False)])
def test_a_wall_punched_through_under_the_volume_floor_is_named_by_the_genus(monkeypatch, h, punched):
    # A 2.5 mm rib meshed at h = 4.82 (D/25) came out with a hole through it, 178 of volume,
    # under the check's floor of 2 h^3: nothing was said. Here the floor is raised past every
    # region, so that only the genus names them: 3 against the bracket's 2, with the hole's place.
    import importlib

    module = importlib.import_module("fepre.distmesh.lost_material")

    monkeypatch.setattr(module, "_MIN_VOLUME", 1e9)
    monkeypatch.setattr(module, "_MIN_SHARE", 1e9)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fepre.distmesh(_bracket(), h)
    named = [str(w.message) for w in caught if "genus" in str(w.message)]
    if punched:
        [message] = named
        assert message.startswith("distmesh: the mesh's surface has genus 3 where the model's has 2 (a wall thinner")
        assert re.search(r"about \d+ near \((5\d|6\d|7\d|8\d)\.\d+, (29|30)\.\d+, 1\d\.\d+\), 2\.5 thick", message)
    else:
        assert named == []


def test_a_mesh_over_its_triangle_models_volume_is_explained_by_bridged_gaps():
    # octagonal_pocket at D/25 came out 5.7% over, explained by "chords' sag, parts thinner than
    # h are lost", which can only make a mesh short
    import pyvista as pv

    from fepre.distmesh.lost_material import volume_message

    ball = sdf.mesh(pv.Sphere(radius=1.0, theta_resolution=64, phi_resolution=64))
    unit = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0, 0, 0]], float)
    cells = np.array([[6, 0, 2, 4], [6, 2, 1, 4], [6, 1, 3, 4], [6, 3, 0, 4], [6, 2, 0, 5], [6, 1, 2, 5], [6, 3, 1, 5],
                      [6, 0, 3, 5]])
    octahedron = 1.5 * unit  # 4.5 against the ball's 4.18
    line = volume_message(ball, ball, octahedron, cells, (-2, -2, -2), (2, 2, 2), 1.0, False)
    assert line.startswith("the mesh's volume is 7.7% over the model's (4.5 against 4.179)")
    assert "gaps, pockets or holes narrower than h are bridged" in line and "lose their chords' sag" not in line
    # a hole's chords cut into its void: a perforated plate that kept its 135 holes was told
    # they were bridged
    assert "a hole's wall or a concave surface curved at the scale of h gains its chords' sag" in line


def test_the_exact_volume_of_a_winding_model_serves_the_warning_not_the_refusal():
    import pyvista as pv

    from fepre.distmesh.lost_material import mesh_model_volume

    ball = pv.Sphere(radius=1.0, theta_resolution=48, phi_resolution=48)
    open_ball = ball.extract_cells(np.flatnonzero(ball.cell_centers().points[:, 2] < 0.9)).extract_surface()
    model = sdf.mesh(open_ball, inside="winding")
    box = (np.full(3, -2.0), np.full(3, 2.0))
    assert mesh_model_volume(model, model, *box) == pytest.approx(model.volume)
    assert mesh_model_volume(model, model, *box, closed=True) is None
    closed = sdf.mesh(ball)
    assert mesh_model_volume(closed, closed, *box, closed=True) == pytest.approx(closed.volume)
    assert mesh_model_volume(closed, closed, np.full(3, -0.5), np.full(3, 2.0)) is None  # the box cuts it


def test_the_lost_material_message_says_what_h_resolves():
    """A gear's 2.8 tooth at h = 2.78 was "2.8 thick" where "thinner than h = 2.77906 resolves"."""
    from fepre.distmesh.lost_material import LostRegion, lost_material_message

    message = lost_material_message([LostRegion((-23.11, 39.91, 5.02), 2.8, 103.0)], 2.77906)
    assert message.startswith("the mesh leaves out about 103 (volume) of the model where it is thinner than two "
                              "elements of h = 2.77906: about 103 near (-23.11, 39.91, 5.02), 2.8 thick; mesh with "
                              "h <= 1.4, or with h=(1.4, 2.779)")


@pytest.mark.slow
def test_a_thin_rib_lost_with_the_boss_it_meets_is_named_by_the_rib():
    """A new user's gmsh housing at D/25: a 1.2 rib lost with a strip of the floor or the 3.5 wall
    of the boss it meets was named "9.17 thick" (coarse STL) and "3.11" (fine): the chords came
    from the region's deepest node, at the junction or in the floor. The advice then left the
    rib out."""
    floor = sdf.box((80, 60, 2.5), center=(40, 30, 1.25))
    rib = sdf.box((37.5, 1.2, 15), center=(21.25, 30, 10.0))
    boss = sdf.cylinder(6.0, 25.0).translate((40, 30, 15.0)) - sdf.cylinder(2.5, 40.0).translate((40, 30, 20.0))
    with pytest.warns(fepre.ResolutionWarning, match=r"leaves out about .*, 1\.2 thick; mesh with h <= 0\.6, or with "
                                                     r"h=\(0\.6, 4\.3\)"):
        fepre.distmesh(floor | rib | boss, 4.3)


def test_a_lap_joints_clearance_is_named_as_the_gap_it_is():
    """A new user's two 1 mm plates lapped with a 0.1 clearance, at h = 0.42: the region filled
    takes in the clearance and the step where the upper plate ends, its deepest node in the step,
    and it was "a concave corner filled 0.52 deep", no h. Its narrowest gap between parallel
    walls names it."""
    lower = sdf.box((5.0, 2.5, 1.0), center=(2.5, 0.0, 0.5))
    upper = sdf.box((5.0, 2.5, 1.0), center=(5.5, 0.0, 1.6))  # 2 of overlap, 0.1 above
    with pytest.warns(fepre.ResolutionWarning, match=r"adds about .* a gap 0\.1 wide; mesh with h <= 0\.05 to keep"):
        fepre.distmesh(lower | upper, 0.42)


def _monte_carlo_volume(model, count=2_000_000, seed=3):
    """An independent volume: the share of random points of the model's box inside it."""
    lower, upper = (np.asarray(b, float) for b in model.bounds)
    points = lower + (upper - lower) * np.random.default_rng(seed).random((count, 3))
    return float(np.mean(np.asarray(model(points)) < 0) * np.prod(upper - lower))


@pytest.mark.parametrize("model, exact", [
    (sdf.sphere(1.0), 4 / 3 * np.pi),
    (sdf.box((2.0, 3.0, 4.0)), 24.0),
    (sdf.torus(2.0, 0.5), 2 * np.pi**2 * 2.0 * 0.25),
])
def test_a_models_volume_is_estimated_from_its_values_on_a_grid(model, exact):
    # the checks' grid is at h / 4; at h = 1 (a box 2 wide at D/5) the share of each node's cell
    # alone is 2.3% over on the box, 2.5% on the torus; extrapolated from every second node
    from types import SimpleNamespace

    from fepre.distmesh.model_volume import sampled_volume
    from fepre.sampling import sample

    for h in (1.0, 0.5):
        lower, upper = (np.asarray(b, float) for b in model.bounds)
        grid = sample(model, spacing=h / 4, bounds=(tuple(lower - h), tuple(upper + h)), dtype="float64", band=h)
        values = np.asarray(grid["sdf"]).reshape(grid.dimensions[::-1])
        estimate = sampled_volume([SimpleNamespace(values=values, step=np.asarray(grid.spacing), mine=None)])
        assert abs(estimate.volume - exact) <= max(estimate.uncertainty, 0.006 * exact)
        # the uncertainty is the error of the finer sum alone (a third of its difference from the
        # coarser): at spacing 0.25 the box's 2.3% (extrapolated: exact), the sphere's 1.8%
        assert estimate.uncertainty <= (0.03 if h == 1.0 else 0.01) * exact


def test_a_function_models_mesh_short_of_its_volume_warns_with_the_h_that_keeps_it():
    # a new user's sphere(2) | capsule(0.6) at h = 1 came out 7% short with no warning: the
    # volume check knew only triangle-mesh models' exact volumes
    model = sdf.sphere(2.0) | sdf.capsule((0, 0, 0), (5, 0, 0), 0.6)
    reference = _monte_carlo_volume(model)  # 37.4
    mesh, lines, named = _volume_warning(model, 1.0)
    error = mesh.volume / reference - 1
    assert error < -0.05
    assert len(lines) == 1 and "short of the model's" in lines[0] and "estimated from the model" in lines[0]
    stated = float(re.search(r"against about ([0-9.]+)\)", lines[0]).group(1))
    assert stated == pytest.approx(reference, rel=0.01)
    assert named[0] == pytest.approx(1.0 * (0.005 / abs(mesh.volume / stated - 1)) ** (1 / 1.5), rel=0.03)
    # a sphere meshed fine enough is within 1% and says nothing: 3 h^2 / 8 r^2 short by its chords
    mesh, lines, _ = _volume_warning(sdf.sphere(1.0), 0.12)
    assert lines == [] and mesh.volume == pytest.approx(4 / 3 * np.pi, rel=0.01)


def test_a_graded_function_models_volume_is_estimated_on_its_zone_grids():
    # with the automatic size field the checks sample each zone at its octave; the estimate adds
    # the zones' nodes once each
    from fepre.distmesh.lost_material import material_candidates

    model = sdf.sphere(2.0) | sdf.capsule((0, 0, 0), (5, 0, 0), 0.6)
    points, tets = _lattice_mesh(2.5, 0.5)
    size = lambda p: 0.2 + 0.3 * np.abs(np.asarray(p)[:, 0])  # 0.2 to 2.4: zones of four octaves
    _, _, grid, graded = material_candidates(model, points, tets, 0.2, size)
    _, _, _, uniform = material_candidates(model, points, tets, 0.2, None)
    assert grid is None  # zone grids, not one
    reference = _monte_carlo_volume(model)
    for estimate in (graded, uniform):
        assert estimate.volume == pytest.approx(reference, rel=0.01)
