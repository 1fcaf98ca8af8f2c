"""What editors show on hover for mechanism and scenario files: one description per property.

:data:`FIELD_DOCS` (every property of every model, keyed by the model's name, its ``$defs``
entry) and :data:`EXAMPLES` (examples of the main keys), applied to the generated JSON Schemas by
:func:`mechkin.config.schema_files.document`. Data only. Split out of ``schema_files.py`` (issue
23: modules that fit in a head).

Imports: nothing.
"""

from __future__ import annotations

# ---- editor documentation ----------------------------------------------------------------------
# One description per property of every model, keyed by the model's name (its ``$defs`` entry).
# ``L`` = the file's length unit, ``A`` = its angle unit (``units:``). The ik section's models
# (mechkin/config/ik_spec.py) are documented here too, so their spec file stays untouched. A
# default is appended from the schema's ``default``; a stale entry (no such property) is an error.

_L = "[length unit: m or mm, from units.length]"
_A = "[angle unit: rad or deg, from units.angle]"
_NR = "Newton-Raphson"

FIELD_DOCS: dict[str, dict[str, str]] = {
    "MechanismSpec": {
        "name": "Name of the mechanism (letters, digits, _ . -).",
        "description": "One-line description shown by `mechkin info`.",
        "notes": "Free text: sources, paper tables, conventions.",
        "units": "Units of every number in this file; converted to SI (m, rad) once on loading.",
        "dh_convention": "D-H convention of the joints placed by `dh`: standard (Denavit-"
                         "Hartenberg) or modified (Craig).",
        "base": "The fixed link (ground); default: the first link. `floating`: the first "
                "link moves, carried from the world by 6 virtual joints base_x, base_y, base_z, "
                "base_yaw, base_pitch, base_roll (inputs of fk, unknowns of ik).",
        "base_pose": f"Home pose of a floating base: xyz {_L}, rpy {_A}.",
        "couplings": "Linear joint couplings joint = multiplier * master + offset (URDF "
                     "<mimic>): the coupled joints are dependent, solved with the loop closure.",
        "links": "The rigid bodies of the spanning tree (at least one).",
        "joints": "Joints of the spanning tree, each between a parent (link or frame) and a "
                  "child link; the chains are cut at the cut links (kim1995 §2).",
        "cuts": "Cut links (kim1995 §2): pairs of frames that must coincide, closing the loops "
                "of a closed or complex chain.",
        "independent": "The independent (actuated) joints q_v (kim1995 §2); every other joint "
                       "is dependent (q_u, solved by loop closure). Required with cuts; default "
                       "(open chain): every joint.",
        "end_effector": "Frame whose pose is the hand {H}: the pose that meets the precision "
                        "points (kim1995 §5); needed by ik, track and workspace (unless they "
                        "name a frame).",
        "gravity": f"Gravity vector in the base frame {_L} per s^2; default [0, 0, -9.81] m/s^2.",
        "drawing": "How stick drawings (stick.png, the MCAP scene) show the mechanism: plates "
                   "as filled polygons; links are always drawn joint to joint.",
        "closed_form": "Closed-form inverse kinematics that fits this structure (kim1995 "
                       "stewart / direct_drive, lee_spherical); parameters read from the "
                       "geometry.",
    },
    "DrawingSpec": {
        "plates": "Plates and platforms drawn as filled polygons (kim1995 Figs. 2, 4, 6: the "
                  "Stewart base and moving plates), each through frames or joints of one link.",
        "auto_plates": "Draw every other link that closes a loop (has a cut frame) or carries "
                       "three or more joints as the convex hull of its joints and cut frames, "
                       "when they span a plane. A declared plate on a link wins.",
    },
    "PlateSpec": {
        "name": "Name of the plate (legend entry of stick.png).",
        "frames": "At least three frame names (link frames or named frames) or joint names (the "
                  "origin of the joint's axis frame; a universal or spherical joint by its "
                  "written name), all fixed on one link, in drawing order around the polygon.",
        "description": "Free text about the plate.",
    },
    "Units": {
        "length": "Length unit of the numbers in this file.",
        "angle": "Angle unit of the numbers in this file.",
    },
    "FrameSpec": {
        "name": "Name of the frame (unique in the mechanism; used by cuts, end_effector, "
                "parent).",
        "xyz": f"Position of the frame in its link frame {_L}.",
        "rpy": f"Orientation: URDF roll-pitch-yaw about the link's x, y, z {_A}.",
    },
    "InertialSpec": {
        "mass": "Mass [kg].",
        "com": f"Centre of mass in the link frame {_L}.",
        "inertia": "About the centre of mass, in kg (length unit)^2: [Ixx, Iyy, Izz, Ixy, "
                   "Ixz, Iyz] (MuJoCo's fullinertia order, not URDF's), or by URDF's names "
                   "{ixx, ixy, ixz, iyy, iyz, izz}.",
    },
    "InertiaByName": {k: f"I{k[1:]} (URDF <inertia {k}=...>)." for k in
                      ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    "LinkSpec": {
        "name": "Name of the link (unique in the mechanism).",
        "description": "Free text about the link.",
        "frames": "Named frames fixed on the link (tool points, cut-link frames).",
        "inertial": "Mass, centre of mass and inertia (needed by track dynamics: rnea).",
        "visuals": "What viewers draw for the link (URDF <visual>; written by mechkin import "
                   "from a URDF's visuals or an MJCF file's geoms); without it, geometry is "
                   "generated from the joints and frames.",
    },
    "VisualSpec": {
        "mesh": "Mesh file: a package://, file:// or http(s):// URI, or a path relative to "
                "this file (written as a file:// URI). Never opened by mechkin; the viewer "
                "loads it.",
        "scale": "Scale of the mesh along x, y, z (dimensionless: the mesh keeps its own "
                 "unit).",
        "box": f"A box: full sizes along x, y, z {_L}.",
        "cylinder": f"A cylinder along z: [radius, length] {_L}.",
        "sphere": f"A sphere: radius {_L}.",
        "xyz": f"Position of the geometry in the link frame {_L}.",
        "rpy": f"Orientation: URDF roll-pitch-yaw about the link's x, y, z {_A}.",
        "rgba": "Colour, red green blue alpha in 0..1; without it a mesh keeps its own "
                "colours.",
    },
    "DHSpec": {
        "a": f"D-H link length a {_L}.",
        "alpha": f"D-H link twist alpha {_A}.",
        "d": f"D-H link offset d {_L} (for a prismatic joint: offset added to q).",
        "theta": f"D-H joint angle offset theta {_A} (for a revolute joint: added to q).",
    },
    "OriginSpec": {
        "xyz": f"Translation of the joint frame in the parent frame {_L}.",
        "rpy": f"Roll-pitch-yaw of the joint frame after the translation {_A}.",
    },
    "JointSpec": {
        "name": "Name of the joint (unique; compound joints expand to <name>_1.._3).",
        "type": "revolute / prismatic (1 DOF); universal (2) and spherical (3) revolutes with "
                "concurrent axes.",
        "parent": "Parent link or named frame.",
        "child": "Child link driven by the joint.",
        "description": "Free text about the joint.",
        "dh": "Placement by D-H parameters (revolute/prismatic only; not with origin or axis).",
        "origin": "Placement by xyz + rpy on the parent (not with dh).",
        "axis": "Joint axis in the joint frame (with origin; 1-DOF joints). Default z.",
        "axes": "Axes of a universal (2) or spherical (3) joint, successive body axes. Default "
                "x-y resp. x-y-z.",
        "offset": f"Joint offset added to q {_A} (prismatic: {_L}); one per axis for compound "
                  "joints.",
        "limits": f"Joint limits [lo, hi] {_A} (prismatic: {_L}); one pair, or one per axis.",
        "home": f"Home configuration {_A} (prismatic: {_L}); one per axis for compound joints.",
        "velocity_limit": f"Joint velocity limit (> 0) {_A} per s (prismatic: {_L} per s), as "
                          "URDF <limit velocity=>; one, or one per axis. Written by export; "
                          "not a track default (track.limits.qd).",
        "torque_limit": "Joint torque limit (> 0) [N m] (prismatic: force [N]), as URDF <limit "
                        "effort=>; one, or one per axis. Written by export; not a track default "
                        "(track.limits.torque).",
    },
    "CouplingSpec": {
        "joint": "The coupled (dependent) joint: q_joint = multiplier * q_master + offset "
                 "(URDF <mimic>, MJCF <equality><joint>); a constraint row of phi.",
        "master": "The joint it follows.",
        "multiplier": "Joint unit per master unit (file units).",
        "offset": "In the coupled joint's unit (file units).",
    },
    "CutSpec": {
        "name": "Name of the cut link (kim1995 §2).",
        "frames": "The two frames [a, b] on two branches of the tree that must coincide.",
        "mask": "Subset of the six closure equations (x, y, z relative position in frame a; "
                "rx, ry, rz vector part of the relative Euler parameters). Default: all six.",
        "description": "Free text about the cut.",
    },
    "ScenarioSpec": {
        "name": "Name of the scenario (names the output folder).",
        "task": "The task to run: fk, ik, track or workspace; needs its section (ik: ik or "
                "biped).",
        "description": "One-line description.",
        "mechanism": "Path of the mechanism file, relative to this file (optional for track "
                     "and workspace).",
        "units": "Units of every number in this file (independent of the mechanism file's).",
        "fk": "Forward kinematics: the motion of the independent joints (task: fk).",
        "ik": "Inverse kinematics at precision points (kim1995 §5; task: ik).",
        "track": "Conveyor tracking / time-optimal motion by DP in the phase plane (park; "
                 "task: track).",
        "workspace": "Workspace and dexterity maps (lee sigma_KI, joint or task-space sweeps; "
                     "task: workspace).",
        "biped": "Closed-form biped inverse kinematics on an inclined plane (hwang2023; "
                 "task: ik).",
        "outputs": "Which output files to write besides summary.json.",
        "expect": "Reference values checked after the run (from papers or closed forms).",
    },
    "OutputsSpec": {
        "csv": "Write the CSV tables.",
        "plots": "Write the PNG plots.",
        "mcap": "Write the MCAP recording (Foxglove).",
    },
    "ExpectSpec": {
        "key": "Dot path into summary.json, e.g. targets.0.q_v.q1.",
        "value": "Expected number (or list), compared with absolute tol (not with min/max).",
        "tol": "Absolute tolerance of value, in unit.",
        "min": "Lower bound (instead of value).",
        "max": "Upper bound (instead of value).",
        "unit": "Unit of value/tol/min/max when not SI; 1 = dimensionless. Default SI.",
        "source": "Where the reference comes from (paper, table, equation).",
    },
    "TimeSpec": {
        "start": "Start time [s].",
        "stop": "Stop time (inclusive) [s].",
        "step": "Time step [s].",
    },
    "MotionSpec": {
        "type": "constant (value), ramp (from -> to over the time span) or sinusoid (offset + "
                "amplitude sin(2 pi frequency t + phase)).",
        "value": f"Constant value {_A} (prismatic: {_L}); type constant.",
        "from": f"Ramp start value {_A} (prismatic: {_L}); type ramp.",
        "to": f"Ramp end value {_A} (prismatic: {_L}); type ramp.",
        "offset": f"Sinusoid offset {_A} (prismatic: {_L}).",
        "amplitude": f"Sinusoid amplitude {_A} (prismatic: {_L}); type sinusoid.",
        "frequency": "Sinusoid frequency [Hz]; type sinusoid.",
        "phase": "Sinusoid phase [rad].",
    },
    "ToleranceSpec": {
        "phi": f"Loop-closure residual ||phi|| below which {_NR} stops (kim1995 §5.1 "
               "epsilon_v).",
        "dq": f"Step size ||dq_u|| below which {_NR} stops (kim1995 §5.1 epsilon_w).",
        "max_iter": f"Maximum {_NR} iterations per configuration.",
    },
    "FkSpec": {
        "time": "Time grid of the motion generators (with motion).",
        "motion": "Motion generator per independent joint (needs time; not with table/csv).",
        "table": "Columns t [s] and one per independent joint (file units); not with "
                 "motion/csv.",
        "csv": "CSV file (relative to the scenario) with t_s and <joint>_rad|_deg|_m|_mm "
               "columns; not with motion/table.",
        "initial_guess": f"Start of the loop closure: joint values by name {_A} ({_L} for "
                         "prismatic); picks the assembly mode followed.",
        "tolerances": f"{_NR} tolerances of the loop closure (kim1995 §5.1).",
        "snapshots": "Number of configurations drawn in the snapshot plot.",
        "assembly": "one: the mode of initial_guess; all: also every assembly mode at the "
                    "first configuration (multi-start).",
        "assembly_starts": "Seeded multi-start count for assembly: all.",
        "assembly_at": "Extra independent-joint configurations (by name, file units) to list "
                       "assembly modes at (needs assembly: all).",
        "base": "Moving or displaced base T_0(t) (kim1995 §5.1 Step 1): pose of the base frame "
                "in a world frame; outputs are then in the world frame.",
        "base_pose": f"Constant pose of a floating base (base: floating): xyz {_L}, URDF rpy "
                     f"{_A}; sets base_x .. base_roll at every step (not with those joints in "
                     "the motion, table or csv).",
    },
    "BaseSpec": {
        "pose": "Constant base pose (xyz, rpy); not with motion/table/csv.",
        "motion": "Generator per base coordinate x, y, z (length unit), roll, pitch, yaw (angle "
                  "unit; R = Rz(yaw) Ry(pitch) Rx(roll)); coordinates not given stay 0.",
        "table": "Columns t [s] and any of x, y, z, roll, pitch, yaw (file units), "
                 "interpolated at the fk times by a cubic spline.",
        "csv": "CSV file (relative to the scenario) with t_s and any of x_m|x_mm, ..., "
               "roll_rad|roll_deg, ... columns; interpolated at the fk times.",
        "frame": "Name of the world frame (MCAP frame tree root).",
    },
    "BasePoseSpec": {
        "xyz": f"Base origin in the world frame {_L}.",
        "rpy": f"Base orientation, URDF roll-pitch-yaw (fixed axes x, y, z) {_A}.",
    },
    "EulerSpec": {
        "convention": "Axis sequence as scipy Rotation.from_euler: upper case intrinsic (body "
                      "axes, e.g. ZYX), lower case extrinsic (fixed axes, e.g. xyz); signed "
                      "axes such as X-Y+Z allowed.",
        "angles": f"One angle per axis of convention {_A}.",
    },
    "TargetSpec": {
        "name": "Name of the precision point.",
        "frame": "The frame that meets this pose (default: the end effector). Targets that "
                 "name their frame are solved together, as one target set.",
        "matrix": f"Pose of the hand as a 4x4 homogeneous matrix (translation {_L}).",
        "xyz": f"Position of the hand {_L} (with rpy, euler or quaternion).",
        "rpy": f"Orientation, URDF roll-pitch-yaw: Rz(yaw) Ry(pitch) Rx(roll) {_A} (with xyz).",
        "euler": "Orientation as Euler angles (convention, angles) (with xyz).",
        "quaternion": "Orientation as a quaternion (w, x, y, z) (with xyz).",
        "weights": "Weights of this point (6: position x, y, z, then orientation); default "
                   "the section's weights.",
    },
    "TargetSetSpec": {
        "name": "Name of the target set.",
        "targets": "One target per frame (each with frame: and its own weights), solved "
                   "together with the loop closure and couplings.",
        "base_pose": f"A floating base in this set: free (unknown) or a known pose {{xyz {_L}, "
                     f"rpy {_A}}} it is held at; default the section's base_pose.",
    },
    "RandomTargetsSpec": {
        "count": "Number of reachable random poses (forward kinematics of random joints "
                 "within limits).",
        "seed": "Random seed.",
    },
    "IkToleranceSpec": {
        "grad": "||df/dq_v|| below which the search stops (kim1995 §5.2 Step 6).",
        "max_iter": "Maximum iterations per target (default: the method's).",
        "position": f"Verified position error below which a target counts as reached {_L}.",
        "orientation": f"Verified orientation error below which a target counts as reached "
                       f"{_A}.",
        "closure": "||phi_R|| of the loop closure (kim1995 §5.1).",
        "line": "Tolerance of the golden-section line search (cg-golden).",
    },
    "IkSpec": {
        "variant": "cg-golden only: printed (kim1995 §5.2 as printed: Fletcher-Reeves without "
                   "restarts, Arora's golden section, no passive-limit projection) or robust "
                   "(the default: restarts, a capped bracket, passive limits kept).",
        "targets": "Precision points {P} (kim1995 §5), solved in order.",
        "target_sets": "Sets of targets of several frames (a biped's feet, a humanoid's feet "
                       "and hands), each set solved together; sets in order.",
        "random_targets": "Seeded random reachable targets (besides or instead of targets).",
        "weights": "Default diagonal of W (kim1995 Eq. (9)): position x, y, z, then "
                   "orientation.",
        "initial_guess": f"Start: independent (and optionally dependent) joints by name {_A}.",
        "method": "auto (default: analytic where the joint axes decompose into subproblems, "
                  "else lm), analytic (every branch by subproblems, the one nearest the guess), "
                  "lm (Levenberg-Marquardt), cg-golden (kim1995 §5.2 conjugate gradient with "
                  "golden section) or closed-form.",
        "tolerances": "Stopping and acceptance tolerances.",
        "restarts": "Re-solves of an unreached target from codebook and random starts (0: "
                    "off).",
        "seed": "Random seed of restarts and starts.",
        "warm_start": "Start each point from the previous solution (kim1995 §5.2).",
        "batch": "Solve all targets at once (lm: independent starts; auto / analytic: one "
                 "compiled call).",
        "cg_restart": "Restart period of the conjugate gradient (cg-golden; default: n).",
        "solutions": "one: the solution of method; all: every distinct verified solution "
                     "(complete for analytic and closed forms; not for the 1-D search).",
        "solution_starts": "Seeded multi-start count for solutions: all.",
        "fixed": f"Independent joints held at these values {_A} (a 7R arm's redundant "
                 "joint); the rest solved analytically (auto / analytic).",
        "base_pose": f"A floating base in target sets: free (default, the base pose is an "
                     f"unknown) or a known pose {{xyz {_L}, rpy {_A}}} it is held at.",
    },
    "PathSpec": {
        "type": "line (start, end; park Eq. (7)), arc (start, via, end on a circle) or spline "
                "(C2 through points); r is the normalised arc length.",
        "start": f"Start point of the path {_L}; 2 values: z = 0.",
        "via": f"arc: a third point of the circle, between start and end {_L}.",
        "end": f"End point of the path {_L}.",
        "points": f"spline: at least 3 points, the ends included {_L}.",
        "frame": "Hand frame; default: the end effector.",
        "orientation": "fixed: hold the start (or the given) orientation; slerp: interpolate "
                       "between orientations; free: position only. Default fixed for >= 6 "
                       "joints, else free.",
        "orientations": f"Hand orientations, URDF roll-pitch-yaw [roll, pitch, yaw] {_A}: one "
                        "(fixed), two (slerp: start, end) or one per spline point.",
        "orientation_blend": "slerp between orientations: linear (constant rate) or smooth "
                             "(quintic: rate and acceleration zero at each orientation).",
        "mask": "Task components (x, y, z, rx, ry, rz) instead of orientation.",
    },
    "IkBranchSpec": {
        "initial_guess": f"Start joint values by name {_A}; default: home.",
        "branch": "Joint signs the path must keep, e.g. {q2: positive} (park's elbow q2 > 0).",
        "tolerance": f"Task position error bound {_L}.",
        "orientation_tolerance": "Task orientation error bound [rad].",
    },
    "ConveyorSpec": {
        "part_start": f"Part position at t = 0, X_p(0) (park Eq. (1)) {_L}.",
        "belt_velocity": f"Belt velocity {_L} per s.",
        "belt_acceleration": f"Constant belt acceleration {_L} per s^2 (park §6); default "
                             "none. Needs objective intercept (or time).",
        "part_size": f"Size of the box drawn for the part {_L}.",
    },
    "GridSpec": {
        "N1": "Number of stages in r (park Eq. (23), N1).",
        "N2": "Number of states in r' (park Eq. (24), N2).",
        "nt_fraction": "N_t = round(nt_fraction N2): the part's speed on the r' grid (park "
                       "nt_fraction).",
        "x2_max": "Top of the r' grid [1/s] for objective: time; default: a reachability "
                  "bound.",
    },
    "LimitPairSpec": {
        "min": "Lower limit per joint.",
        "max": "Upper limit per joint.",
    },
    "LimitsSpec": {
        "torque": "Torque limits [N m] (forces [N]) per joint (park Eq. (3)); list = "
                  "symmetric.",
        "qd": f"Joint velocity limits {_A} per s (park Eq. (4)).",
        "qdd": f"Joint acceleration limits {_A} per s^2 (park Eq. (5)).",
        "jerk": f"Joint jerk limits {_A} per s^3 (park Eq. (6)).",
        "q": f"Joint position limits {_A} ({_L} prismatic); default: the mechanism's limits.",
    },
    "TrackSpec": {
        "objective": "tracking (DPCT, park §4), intercept (earliest t_a) or time (minimum "
                     "time rest to rest).",
        "path": "The straight hand line (park Eq. (7)).",
        "ik": "Inverse kinematics along the line (park Eq. (9)).",
        "conveyor": "The part on the belt (needed unless objective: time).",
        "grid": "Phase-plane grid (park Eq. (23)-(24)).",
        "grid_study": "Several grids solved and compared (park §5.2).",
        "limits": "Joint limits (park Eq. (3)-(6)).",
        "dynamics": "rnea (recursive Newton-Euler from the inertials) or closed_form_2link "
                    "(park Table 1).",
        "dp": "Readings of the DP stage (park §4): step time, wait cost, end jerk checks.",
        "cases": "Several limit sets / readings planned and overlaid (park §5.3, Figs. 5-8).",
        "planner": "auto (TOPP-RA for time/intercept with torque, qd or qdd limits and no "
                   "jerk limit, else the DP), dp (phase-plane DP) or topp (TOPP-RA on the "
                   "N1 + 1 points of the grid; time and intercept, no jerk).",
    },
    "DpSpec": {
        "step_time": "trapezoid (dt = 2 dx1 / (x2[j] + x2[l]), default) or euler (park Eq. "
                     "(26) literally: dt = dx1 / x2[j], Eq. (21) forward Euler).",
        "wait_cost": "Cost the wait at rest before the start as park Eq. (18) from t_0 "
                     "(objective tracking only).",
        "jerk_ends": "Check the jerk of the first step (from rest) and the last step too.",
    },
    "CaseSpec": {
        "name": "Case name (legend and summary cases[].name).",
        "limits": "Limits of this case (replace track.limits; {} = joint positions only).",
        "dp": "Readings of this case (replace track.dp).",
    },
    "AxisGridSpec": {
        "range": f"[lo, hi] inclusive {_A}.",
        "n": "Number of grid points.",
    },
    "GammaRangeSpec": {
        "range": f"gamma grid searched [lo, hi] {_A} (lee Fig. 2).",
        "n": "Number of gamma grid points.",
        "mode": "extent (smallest/largest gamma in the workspace) or component (the run "
                "containing ref).",
        "ref": f"gamma the run must contain (mode component) {_A}.",
        "n_alpha": "alpha grid points of this map.",
        "n_beta": "beta grid points of this map.",
    },
    "LeeParametersSpec": {
        "r": f"Top-plate radius r (lee §3) {_L}.",
        "R": f"Base radius R (lee §3) {_L}.",
        "center": f"Centre of rotation P {_L}.",
        "stroke": f"Leg stroke [l_min, l_max] {_L}.",
    },
    "JointRangeSpec": {
        "range": f"Swept range [lo, hi] {_A} ({_L} prismatic); default: the joint's limits.",
        "n": "Grid points (method grid).",
    },
    "SlicesSpec": {
        "axis": "Normal of the section planes.",
        "at": f"Plane offsets {_L}; default: the cloud's median.",
        "thickness": f"Thickness of each slab {_L}.",
    },
    "DesignSpec": {
        "parameter": "Design parameter swept: r, R, l_min or l_max (lee).",
        "values": f"Its values {_L}.",
    },
    "ExecutorSpec": {
        "kind": "process (local processes) or dask (needs address and mechkin[dask]).",
        "address": "Dask scheduler address, e.g. tcp://127.0.0.1:8786 (kind dask).",
    },
    "PositionAxisSpec": {
        "value": f"Fixed coordinate {_L} (not with range).",
        "range": f"[lo, hi] {_L}: the grid or the random box.",
        "n": "Grid points (method grid; 1 = midpoint).",
    },
    "OrientationSpec": {
        "euler": "Euler angles (convention, angles): upper case intrinsic, lower case "
                 "extrinsic, as scipy.",
        "quaternion": "Quaternion (w, x, y, z).",
        "random": "Uniform random orientations (monte_carlo only).",
    },
    "WorkspaceSpec": {
        "kind": "lee_spherical (lee §3 sigma_KI maps), joint_sweep or task_space.",
        "parameters": "lee_spherical: design r, R, center, stroke (default: mechanism file, "
                      "else lee §3.2).",
        "threshold": "lee_spherical: sigma_KI threshold of the dexterous region.",
        "alpha": "lee_spherical: alpha grid (Euler angle alpha).",
        "beta": "lee_spherical: beta grid (Euler angle beta).",
        "isotropy_maps": f"lee_spherical: name -> list of gamma {_A}; one sigma_KI map per "
                         "gamma (lee Figs. 3-5).",
        "gamma_range": "lee_spherical: gamma_min/gamma_max map (lee Fig. 2).",
        "method": "lee_spherical: closed_form or svd; joint_sweep/task_space: grid or "
                  "monte_carlo.",
        "joints": "joint_sweep: swept independent joints by name.",
        "samples": "monte_carlo: number of samples.",
        "seed": "Random seed.",
        "frame": "Mapped frame; default: the end effector.",
        "voxel": f"joint_sweep: edge of the cubes counted for the volume {_L}.",
        "slices": "joint_sweep: section planes of the point-cloud plot.",
        "manipulability": "Compute Yoshikawa manipulability and isotropy.",
        "characteristic_length": f"Length dividing translational Jacobian rows {_L}; default: "
                                 "best conditioning.",
        "seed_from": "joint_sweep: loop closure starts from a solved neighbour or home.",
        "mode_jump": "joint_sweep: threshold of the assembly-mode change report.",
        "chunk": "Samples (poses) per job.",
        "positions": "task_space: per axis x, y, z a value or a range.",
        "orientation": "task_space: orientation of the poses; default identity.",
        "weights": "task_space: diagonal of W (6).",
        "restarts": "task_space: IK restarts per pose.",
        "max_iter": "task_space: IK iterations per pose.",
        "poses": f"Explicit poses: lee [alpha, beta, gamma] {_A}; task_space [x, y, z] or "
                 f"[x, y, z, qw, qx, qy, qz] {_L}.",
        "poses_csv": "CSV of poses relative to the scenario (not with poses).",
        "design": "lee_spherical: design sweep over a parameter.",
        "workers": "Worker processes; default min(cpu count, jobs).",
        "executor": "Where the jobs run (process or dask).",
    },
    "PlaneSpec": {
        "lam_x": f"Plane angle lambda_X (hwang2023 Table 5, XYXY) {_A}.",
        "lam_y": f"Plane angle lambda_Y {_A}.",
        "gam_x": f"Plane angle gamma_X {_A}.",
        "origin": f"A point of the plane {_L}.",
    },
    "BodySpec": {
        "position": f"Position of the body point G (A_0G) {_L}.",
        "theta_x": f"Body turn about world x {_A}.",
        "theta_y": f"Body turn about world y {_A}.",
        "theta_z": f"Body heading theta_z (hwang2023 Eq. 1a) {_A}.",
    },
    "LegTaskSpec": {
        "position": f"End-effector point E in world coordinates {_L} (not with below_hip).",
        "below_hip": f"Offset (x, y) from the plane point below the hip {_L} (Fig. 7).",
        "beta_z": f"beta_Z, toe turned outward {_A}.",
        "beta": f"walk: beta_X of the foot; skate: beta_Y of the blade; roll: start beta_Ya "
                f"{_A}.",
        "theta6": f"Ankle angle theta6: skate with beta_Y unknown (§2.3), roll target (§2.4) "
                  f"{_A}.",
        "beta_end": f"roll: blade tilt beta_Y rolled to {_A}.",
        "branch": "Expected branch: knee back or knee forward.",
        "plane": "This leg's own inclined plane; default the step's.",
    },
    "LegsSpec": {
        "right": "Task of the right leg (theta1..theta6 solved in closed form).",
        "left": "Task of the left leg (theta1..theta6 solved in closed form).",
    },
    "StepSpec": {
        "name": "Name of the step.",
        "mode": "walk (foot), skate (blade) or roll (blade rolling, hwang2023 §2.4).",
        "legs": "Tasks of both legs.",
        "plane": "Inclined plane of this step; default the section's.",
        "body": "Body pose of this step; default the section's.",
        "duration": "Duration of the step [s].",
        "frames": "Frames animating the step.",
        "time_law": "linear or smooth (10 s^3 - 15 s^4 + 6 s^5).",
    },
    "BipedSpec": {
        "plane": "The inclined plane (hwang2023 Table 5).",
        "body": "The body pose A_0G.",
        "mode": "One case: walk, skate or roll (not with sequence).",
        "legs": "One case: tasks of both legs.",
        "name": "Name of the one case.",
        "sequence": "Switching sequence of steps (walk -> skate -> roll); not with mode/legs.",
        "solutions": "one, or all closed-form solutions of each leg.",
    },
}

EXAMPLES: dict[str, dict[str, list]] = {
    "MechanismSpec": {"name": ["puma560"], "independent": [["q1", "q2"]],
                      "end_effector": ["tool"], "units": [{"length": "mm", "angle": "deg"}]},
    "ScenarioSpec": {"name": ["ur5_fk"], "mechanism": ["../mechanisms/ur5.yaml"],
                     "units": [{"angle": "deg"}]},
    "JointSpec": {"dh": [{"a": 0.4318, "alpha": -90}], "limits": [[-160, 160]],
                  "origin": [{"xyz": [0, 0, 0.1], "rpy": [0, 0, 90]}]},
    "CutSpec": {"frames": [["leg1_top", "plate_s1"]]},
    "PlateSpec": {"frames": [["b1", "b2", "b3"], ["u1", "u6", "u5", "u4", "u3", "u2"]]},
    "ExpectSpec": {"key": ["targets.0.q_v.q1"]},
    "GridSpec": {"N1": [50], "N2": [100]},
}
