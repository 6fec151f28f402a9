"""Scenarios of the simulated plant factory: data model, validation, YAML I/O and generator.

A scenario file (YAML, all lengths in metres, map frame: track along +y, the plant row toward +x,
z up) holds:

    name, description, seed         seed drives textures and sensor noise of the cameras
    track:    picking_points [y...]  cart positions (m along map +y), strictly increasing
              backdrop_x             x of the canopy behind the fruit (rendered backdrop)
              aisle_x                x of the opposite row (seen when the waist turns round)
    lighting: intensity, ambient, colour [r, g, b], direction [x, y, z] (the way light travels)
    look:     optional camera/illumination look of the renders (harvest_sim/look.py):
              kind daylight|led|warm (default daylight), background foliage|mixed|film
              (what the canopy plane behind the fruit shows; default mixed), variation 0..1
              (how far the per-camera random look spreads over its documented ranges; 1)
    stems:    [{id, kind: main|truss, radius, points: [[x, y, z], ...]}]
    leaves:   [{id, centre, normal, axis, length, width, colour}]
    fruits:   [{id, position, radius, ripeness, cluster, truss, peduncle, pedicel_top,
                picking_point, reachable, occluded_by: [leaf ids]}]
    generator: knobs that produced the file (informational)

Ripeness is 0..1 and rendered green -> turning -> pink -> red; ground truth "ripe" is
ripeness >= RIPE_THRESHOLD. The peduncle (where the shear cuts) is the stem point above the fruit:
centre + (0, 0, radius + PEDUNCLE_GAP). `reachable` is computed with motion_pkg.kinematics at the
fruit's picking point (cart at that point, waist at 0 or turned by the smallest angle that serves
both arms, RobotGeometry.inverse_waist): the right suction tcp must reach the fruit surface facing
it (target the centre with standoff = radius) and the left shear tcp the peduncle (with the right
arm at its suction pose for the clearance check). The generator's `waist_fraction` places fruit
beside the arms' fixed workspace (WAIST_VIEW_X, WAIST_VIEW_HALF_Y, still fully in both stereo
images at waist 0) that only a turn of the waist brings in reach.

load_scenario() raises ScenarioError naming the file, the field path and the problem.

The code lives in scenario_model (constants and data classes), scenario_yaml (YAML I/O and
validation), scenario_reach (reachability and view checks) and scenario_generator (knobs,
PRESETS, generate); this module re-exports their public names.
"""

from harvest_sim.scenario_generator import (  # noqa: F401
    DEFAULT_KNOBS, PRESETS, generate, knobs_for)
from harvest_sim.scenario_model import (  # noqa: F401
    BACKGROUNDS, FRUIT_SIZES, LOOK_KINDS, PEDUNCLE_GAP, RADIUS_RANGE, RIPE_THRESHOLD,
    SIZE_CLASSES, STAGES, STEM_KINDS, TRACK_RANGE, VIEW_HALF_Y, VIEW_X, VIEW_Z, WAIST_ONLY,
    WAIST_VIEW_HALF_Y, WAIST_VIEW_X, Fruit, Leaf, Lighting, Look, Scenario, ScenarioError, Stem,
    Track, default_peduncle, ripeness_stage)
from harvest_sim.scenario_reach import (  # noqa: F401
    fully_in_view, mark_reachability, reachability, stereo_eyes)
from harvest_sim.scenario_yaml import (  # noqa: F401
    dump_scenario, load_scenario, parse_look, parse_scenario, resolve_scenario, save_scenario)
