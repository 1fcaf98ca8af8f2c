"""``assembly: all`` on Dietmaier's 6-6 Stewart-Gough platform with 40 real postures (issue 24).

Published case: P. Dietmaier, "The Stewart-Gough platform of general geometry can have 40 real
postures", in J. Lenarcic, M. L. Husty (eds.), Advances in Robot Kinematics: Analysis and
Control, Kluwer, 1998, pp. 7-16: a general 6-6 platform whose forward kinematics has all 40
solutions real (the upper bound: 40 complex solutions, Raghavan, ASME J. Mech. Des. 115:277,
1993). The geometry and leg lengths (tests/data/stewart_dietmaier40.yaml, typed in its header)
were read in E. Martyushev's fkSGP, https://github.com/martyushev/fkSGP, python/genSGP.py,
sgpType 100 "general 6-6 SGP with 40 real postures (by P. Dietmaier)" (commit 8bd29e5), which
also prints one of the postures as the instance's ground truth (motionType 0: Rgt, tgt; row 29
of POSES below, 0-based). Dietmaier's paper was not at hand: the count (40) is the published
fact; the 40 poses below are not printed anywhere we could read. They were computed with fkSGP's
python/solver66.py (Martyushev, "Forward kinematics of a general Stewart-Gough platform by
elimination templates", Mech. Mach. Theory 215 (2025) 106170: all 40 complex roots by an
elimination template and an eigenvalue problem; here it returned 40 real roots, Dietmaier's
count), then Newton-polished on the six leg equations to round-off and typed with 13 decimals;
test_reference_poses re-checks them here (legs to 1e-12, all distinct). Each pose: p (m), then
the rotation vector of R (rad); leg i joins the base point a_i and p + R b_i.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from mechkin.model import load_mechanism
from mechkin.model.closure import solve_closure
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.assembly import (
    assembly_modes,
    deflated_newton,
    relax,
    spherical_equivalents,
)

ROOT = Path(__file__).resolve().parents[2]
MECH = ROOT / "tests" / "data" / "stewart_dietmaier40.yaml"
FOURBAR = ROOT / "tests" / "data" / "fourbar.yaml"

# Dietmaier (1998), as typed in fkSGP python/genSGP.py (sgpType 100)
A = np.array([[0, 0, 0], [1.107915, 0, 0], [0.549094, 0.756063, 0],
              [0.735077, -0.223935, 0.525991], [0.514188, -0.526063, -0.368418],
              [0.590473, 0.094733, -0.205018]])
B = np.array([[0, 0, 0], [0.542805, 0, 0], [0.956919, -0.528915, 0],
              [0.665885, -0.353482, 1.402538], [0.478359, 1.158742, 0.107672],
              [-0.137087, -0.235121, 0.353913]])
LEGS = np.array([1, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071])

# the 40 real postures (p_x, p_y, p_z, rotation vector), sorted by p; see the module docstring
POSES = np.array([
    (0.4421986546510, -0.7134942959467, -0.5434944705112,
     -1.8880776044292, -0.8734104072801, -0.5751245785720),
    (0.4430375084206, -0.5586215056700, -0.7011845545471,
     -1.6881179403689, -0.9033377008012, -0.7784344644174),
    (0.4587343945127, -0.3734809322352, -0.8062721305786,
     -1.4903723819802, -0.9148652306095, -0.9728632571817),
    (0.4778914958775, -0.7810987686459, -0.4018761398588,
     -1.7944483765119, -0.5599372757252, 0.4035540214883),
    (0.4846116170744, -0.8739347470126, -0.0372778561696,
     -2.3702906485937, -0.7051389885187, -0.0727549006169),
    (0.4854807803728, -0.2008179875370, -0.8508704647420,
     -1.3183518468042, -0.9144501808022, -1.1385556971001),
    (0.4891221742019, 0.6962299581660, -0.5253792383185,
     1.7900035066944, -0.6551942676600, 0.4362003660204),
    (0.5218476674591, 0.8107202156541, 0.2653445757825,
     2.4206797964578, -0.9618563234924, 0.0861399751268),
    (0.5340033652660, 0.0061740028550, -0.8454598083726,
     -1.1068936548751, -0.9038257026023, -1.3371341437700),
    (0.5350598052410, -0.7495961119943, -0.3896365918372,
     -1.8208812026513, -1.3122859183125, -0.8172810705213),
    (0.5398484183339, 0.6788404019995, 0.4977342602590,
     2.6052280468673, -0.6707642366966, -0.1896066964382),
    (0.5859105970801, 0.1614982575588, -0.7941203215097,
     -0.9268574733904, -0.8890376275098, -1.4993382464475),
    (0.6361117806579, 0.7714519603665, 0.0149557799822,
     1.5963663224204, -0.0213670063427, -1.3133327815489),
    (0.6675320501467, 0.7383170889514, -0.0963786189421,
     -1.8396664868540, 2.2302352047507, -1.0005624734090),
    (0.6797962979846, 0.3480606910183, -0.6455468601227,
     -0.6294438630518, -0.8603912655468, -1.7426593661887),
    (0.6894183177410, 0.5936562997520, -0.4150597317591,
     -1.3381621949068, 1.5250882982665, -1.3091369885474),
    (0.7079629867044, 0.6858684120602, -0.1684426632259,
     -1.5345372044833, 2.1144534163619, -1.1355963265028),
    (0.7191312280437, 0.6338825411691, -0.2846808754611,
     -1.3497707810588, 1.8585097529202, -1.2526562396318),
    (0.7811003856904, 0.0687982303643, -0.6206037310338,
     0.9145219982547, -1.8854317835627, 1.3157212537743),
    (0.8032678161694, -0.2960071155890, 0.5168564626926,
     -1.8655580065737, -1.3905704186751, 0.4480405948089),
    (0.8250801747746, -0.3189256334036, 0.4664001989193,
     1.8776343865282, -0.6781678629456, -2.3575654202969),
    (0.8322846500753, -0.2827517623338, 0.4768162142233,
     -1.6594251506347, 1.0135218422073, 2.2893921739325),
    (0.8543762444964, -0.2942029523708, 0.4283524899618,
     -1.3131465833050, 1.1968740627136, 2.1586827878066),
    (0.8557655786025, -0.3346791574137, 0.3945315400219,
     1.7388974713493, -0.2818928887062, -2.3033436581975),
    (0.8633257144388, 0.0056440279821, -0.5046155524127,
     0.8438793171940, 0.3249851628702, 1.3932621040025),
    (0.8700775053429, -0.4511219989218, -0.1986305031587,
     2.0477573265072, -0.1863771218534, 2.2659108391570),
    (0.8913748580604, -0.0798270405207, -0.4461821444427,
     0.3433217463307, -2.0605294267793, 1.3900020577980),
    (0.9031741228709, -0.4184454086284, 0.0958120231197,
     -0.3312840722033, 1.3551034506227, 1.9129937223656),
    (0.9177780902653, -0.1111761832321, 0.3812128451546,
     -1.3475252427914, -1.3787971570459, 0.8671141296549),
    (0.9558680382336, -0.0469956289983, -0.2900132830380,
     0.1468275177212, 0.4353271882926, 1.5533705965420),
    (0.9580982043911, -0.2840386866925, -0.0370115550153,
     -1.9041992463573, 0.0669172930845, -2.4608302308214),
    (0.9680942754888, 0.2367734161932, -0.0820476882677,
     1.3840374409820, -0.2624741758536, 1.6066183182240),
    (0.9891322924741, 0.1166713375254, 0.0894712634594,
     -0.7818478937523, -0.4834411434084, 1.3278006534389),
    (0.9916134772924, -0.1270160298309, 0.0238671284001,
     -1.6258751994220, -0.0698574227656, -2.4128188944126),
    (0.9935772794044, 0.0796654805363, -0.0803592002336,
     -0.4060235985105, 0.0353037306844, 1.4976154826386),
    (0.9937257532213, 0.1117858473808, 0.0036127150568,
     -0.6087542405152, -0.2155588901086, 1.4208766609598),
    (0.9953675898459, -0.0511993259824, 0.0813756112321,
     -0.4093320881535, -2.5592799464990, 1.4163762175190),
    (0.9985231845855, 0.0311963455129, 0.0444773860735,
     0.3104911977042, 2.5138551920557, -1.5952628511491),
    (0.9989012017693, -0.0415643198068, -0.0216517071556,
     0.5993732604565, 1.8355874606879, -1.7680915532653),
    (0.9996275161053, 0.0261758201161, -0.0077236964199,
     0.3662797175440, 2.1925135789262, -1.6681704523023),
])
# fkSGP's printed ground truth (genSGP.py, motionType 0), to its printed digits
P_GT = np.array([0.955868038233880, -0.046995628998516, -0.290013283037649])
R_GT = np.array([[-0.040450357031281, -0.932229494397471, 0.359599691867884],
                 [0.983337493748685, 0.026695523074364, 0.179818582009314],
                 [-0.177231887661606, 0.360881585597300, 0.915616371179918]])


def _poses() -> tuple[np.ndarray, np.ndarray]:
    return POSES[:, :3], Rotation.from_rotvec(POSES[:, 3:]).as_matrix()


def _leg_lengths(p: np.ndarray, R: np.ndarray) -> np.ndarray:
    """|p + R b_i - a_i| (k, 6) for poses p (k, 3), R (k, 3, 3)."""
    return np.linalg.norm(p[:, None] + np.einsum("kij,lj->kli", R, B) - A[None], axis=-1)


def test_reference_poses():
    p, R = _poses()
    assert POSES.shape == (40, 6)
    assert np.abs(_leg_lengths(p, R) - LEGS).max() < 1e-12
    # 40 distinct postures (the closest two differ by 0.038 m in p)
    d = np.linalg.norm(p[:, None] - p[None], axis=-1) + np.linalg.norm(
        R[:, None] - R[None], axis=(-2, -1))
    assert np.sort(d + np.eye(40) * 9, axis=None)[0] > 1e-2
    # the published ground truth is one of them
    k = np.argmin(np.linalg.norm(p - P_GT, axis=1))
    assert k == 29
    assert np.abs(p[k] - P_GT).max() < 1e-9 and np.abs(R[k] - R_GT).max() < 1e-9


def test_assembly_all_finds_the_40_real_postures():
    mech = load_mechanism(MECH)
    assert np.allclose(mech.home[mech.independent], LEGS)
    modes = assembly_modes(mech, LEGS)  # the defaults of fk's assembly: all
    assert modes.count == 40
    assert np.abs(modes.q[:, mech.independent] - LEGS).max() == 0.0
    kin = forward_kinematics(mech, modes.q)
    assert np.abs(closure_residual(mech, kin)).max() <= 1e-10
    T = kin.frames(mech, [mech.end_effector])[:, 0]
    got_p, got_R = T[:, :3, 3], T[:, :3, :3]
    # the legs of each posture, independently of the joint chain
    assert np.abs(_leg_lengths(got_p, got_R) - LEGS).max() <= 1e-10
    # one to one with the reference postures, within 1e-8
    p, R = _poses()
    dist = np.maximum(np.abs(got_p[:, None] - p[None]).max(axis=-1),
                      np.abs(got_R[:, None] - R[None]).max(axis=(-2, -1)))
    match = np.argmin(dist, axis=1)
    assert sorted(match.tolist()) == list(range(40))
    assert dist[np.arange(40), match].max() < 1e-8
    # limits: universal joints [-90, 90]^2 mean leg i points upwards (B_i above A_i); only
    # reference posture 33 has all six legs so
    up = np.all((p[:, None] + np.einsum("kij,lj->kli", R, B) - A[None])[..., 2] >= 0, axis=1)
    assert np.flatnonzero(up).tolist() == [33]
    assert modes.within_limits.tolist() == up[match].tolist()
    inside = np.all((modes.q >= mech.lower - 1e-9) & (modes.q <= mech.upper + 1e-9), axis=1)
    assert inside.tolist() == modes.within_limits.tolist()


def test_relax_assembles_with_the_actuated_joints_free():
    mech = load_mechanism(FOURBAR)
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (16, mech.n))
    out, ok = relax(mech, q)
    assert ok.sum() >= 12
    assert np.abs(closure_residual(mech, forward_kinematics(mech, out[ok]))).max() < 1e-12


def test_deflated_newton_leaves_the_known_mode():
    """Started beside the four-bar's open mode and deflated at it, Newton reaches the crossed
    mode, where plain Newton from the same start returns to the open one."""
    mech = load_mechanism(FOURBAR)
    qv = np.radians([60.0])
    modes = assembly_modes(mech, qv, starts=32)
    assert modes.count == 2
    dep = mech.dependent
    start = modes.q[:1, dep] + 0.3
    got = deflated_newton(mech, qv, start, modes.q[:1, dep])
    plain = solve_closure(mech, qv[None], start)
    assert len(got) == 1 and plain.ok[0]
    ref = forward_kinematics(mech, modes.q).frames(mech)[:, :, :3, 3]
    for q_w, mode in ((got, 1), (plain.q[:, dep], 0)):
        key = forward_kinematics(mech, mech.assemble(qv[None], q_w)).frames(mech)[0, :, :3, 3]
        d = np.abs(ref - key[None]).max(axis=(1, 2))
        assert d[mode] < 1e-9 < d[1 - mode]


def test_spherical_equivalents_put_a_mode_back_within_the_limits():
    """Each spherical joint's other Euler solution (a + pi, pi - b, c + pi) leaves the middle
    angle's [-90, 90] deg limits with the same frames; the within-limits one is restored."""
    mech = load_mechanism(MECH)
    home = solve_closure(mech, LEGS[None], mech.home[mech.dependent][None]).q[0]
    flipped = home.copy()
    for g in mech.groups:
        if g.type == "spherical":
            a, b, c = g.joints
            flipped[[a, b, c]] = flipped[a] + np.pi, np.pi - flipped[b], flipped[c] + np.pi
    assert not np.all(flipped <= mech.upper + 1e-9)
    real = [f for f in range(len(mech.frame_names))
            if mech.frame_link[f] not in mech.virtual_links]
    F = forward_kinematics(mech, np.vstack([home, flipped])).frames(mech, real)
    assert np.abs(F[0] - F[1]).max() < 1e-12
    out = spherical_equivalents(mech, np.vstack([home, flipped]))
    assert np.abs(out - home).max() < 1e-12
