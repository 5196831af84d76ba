"""iRonCub-Mk1_1 against iCubGazeboV2_5: the numbers that turn one into the other.

Source of the figures: the public iRonCub-Mk1_1 URDF (ironcub-mk1-software, commit 36e4586,
BSD-3-Clause, (c) Istituto Italiano di Tecnologia). Only the values that differ from the
`icub-models` iCubGazeboV2_5 model are listed: joint origins (shoulders 17.5 mm lower, left
shoulder chain, elbows, neck), link inertials (Mk1_1 masses, and true small-link inertias where
iCubGazeboV2_5 inflates them to 0.01 kg m^2), and the added links (four jets, the chest marker,
the sole corners). Angles in radians, lengths in metres, masses in kg, inertias in kg m^2 about
the centre of mass, as (ixx, ixy, ixz, iyy, iyz, izz).
"""

from dataclasses import dataclass

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class JointOrigin:
    xyz: Vec3
    rpy: Vec3
    axis: Vec3


@dataclass(frozen=True)
class LinkInertial:
    mass: float
    com_xyz: Vec3
    com_rpy: Vec3
    inertia: tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class AddedLink:
    joint: str
    parent: str
    xyz: Vec3
    rpy: Vec3
    inertial: LinkInertial | None


# The Mk1_1 file gives l/r_elbow_1 (0.861 kg, elbow plus jet mount) a non-positive-definite
# inertia. We keep its mass and centre of mass and use a uniform solid box of 0.18 x 0.06 x
# 0.06 m (elbow-to-jet mount along x) instead: ixx = m (b^2 + c^2) / 12, and so on.
ELBOW_MOUNT_BOX = (0.18, 0.06, 0.06)


def box_inertia(mass: float, size: Vec3) -> tuple[float, float, float, float, float, float]:
    a, b, c = size
    return (
        mass * (b * b + c * c) / 12,
        0.0,
        0.0,
        mass * (a * a + c * c) / 12,
        0.0,
        mass * (a * a + b * b) / 12,
    )


JOINT_ORIGINS = {
    "l_shoulder_pitch": JointOrigin(
        xyz=(0.120258000190735, 0.07529999999999999, 0.008034),
        rpy=(0.0, 0.523598883792035, -3.141592648178681),
        axis=(-0.9659259261732691, -7.758694154976075e-15, -0.25881927552505174),
    ),
    "l_shoulder_roll": JointOrigin(
        xyz=(0.007580265732236205, 0.0, 0.014210592774007907),
        rpy=(-0.2705976128330147, 0.25268017210070187, 1.5015567953707367),
        axis=(-0.2588190174889569, -1.1253323287226445e-17, 0.9659259953138497),
    ),
    "l_shoulder_yaw": JointOrigin(
        xyz=(0.025313329844247154, 1.2922216940935982e-07, -0.005396821114290115),
        rpy=(-0.2526895449300091, -0.00851861944331826, -0.06703989350788468),
        axis=(0.9659258393523219, -5.74303850210394e-15, 0.2588189963497913),
    ),
    "l_elbow": JointOrigin(
        xyz=(0.0, -0.02000000036832994, 0.0792599999070578),
        rpy=(0.0, -1.3089969894682885, -3.1415926535896865),
        axis=(-2.8153947961711753e-14, -1.0, 4.189584876898852e-14),
    ),
    "r_shoulder_pitch": JointOrigin(
        xyz=(-0.120257999809265, 0.07529999999999999, 0.008034),
        rpy=(0.0, -0.523598883792035, 3.141592653589793),
        axis=(-0.965925926173269, 0.0, 0.25881927552505174),
    ),
    "r_elbow": JointOrigin(
        xyz=(0.0, -1.4000000000014001e-05, 0.07925999999999998),
        rpy=(0.0, 1.3089970069677397, 0.0),
        axis=(2.220446049250313e-16, 1.0000000000000002, 0.0),
    ),
    "neck_pitch": JointOrigin(
        xyz=(0.0, 0.1553, 0.0053103000000000004),
        rpy=(-0.009691561895004074, 0.0, 0.0),
        axis=(-1.0, 0.0, 0.0),
    ),
    "neck_roll": JointOrigin(
        xyz=(0.0, 0.009499864480011971, 0.020800033911547038),
        rpy=(0.0, 0.0, 0.0),
        axis=(0.0, 1.8017533007091882e-10, 0.9999999628183933),
    ),
    "neck_yaw": JointOrigin(
        xyz=(0.0, -0.022343467917102816, -0.020800006539361923),
        rpy=(0.0, 0.0, 0.0),
        axis=(0.0, 0.9999999628183934, -1.8017532951839303e-10),
    ),
}
LINK_INERTIALS = {
    "chest": LinkInertial(
        mass=11.145012,
        com_xyz=(0.001377300190735, 0.072282, -0.07247350000000001),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(
            0.07324404084923891,
            1.2330205546753283e-06,
            -0.0005526366282286879,
            0.09910846133182856,
            0.0002702241286597484,
            0.08450746994390157,
        ),
    ),
    "head": LinkInertial(
        mass=1.50691,
        com_xyz=(-0.000574157809265, 0.11351039603698956, -0.007539178253350532),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.00680478, -1.60267e-05, 7.28166e-05, 0.00634736, 0.000292091, 0.00478116),
    ),
    "l_ankle_2": LinkInertial(
        mass=0.265122,
        com_xyz=(0.0011446999999999985, 3.599999999992498e-06, -0.03852),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(0.000327222, -4.74606e-08, 4.94571e-08, 0.000248285, -4.29975e-06, 0.000150937),
    ),
    "l_elbow_1": LinkInertial(
        mass=0.861052,
        com_xyz=(0.08895156524144233, -0.0038649995796335435, 0.01753111115436965),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000866459, 0.00107731, 0.00126826, -0.00295157, 0.00010435, -0.00230506),
    ),
    "l_hip_3": LinkInertial(
        mass=0.126212,
        com_xyz=(-0.00012290000000000217, -0.0002822999999999992, 0.008718000000000031),
        com_rpy=(-1.5707963267948961, 0.0, -1.5707963267948961),
        inertia=(3.27938e-05, 2.67901e-07, -4.41463e-09, 5.69957e-05, 3.32338e-08, 3.26449e-05),
    ),
    "l_lower_leg": LinkInertial(
        mass=1.8324,
        com_xyz=(0.0009997999999999951, 0.0034968999999999695, -0.088567),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(
            0.005272923978185719,
            -0.00029820080035259695,
            8.41488031988615e-05,
            0.0018943923873043858,
            -0.00029014597407562784,
            0.005687448808126723,
        ),
    ),
    "l_shoulder_1": LinkInertial(
        mass=0.114882,
        com_xyz=(0.012265033463409528, -3.300011353971066e-05, -0.0032056591871175155),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(2.24676e-05, -1.77064e-08, 3.55951e-06, 2.29712e-05, 6.57597e-08, 1.00139e-05),
    ),
    "l_shoulder_2": LinkInertial(
        mass=0.238162,
        com_xyz=(0.021473511153041913, 0.00026800955971750806, -0.019406690705168747),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000159621, 1.19701e-07, -1.29687e-05, 0.000222574, 1.20112e-06, 0.000120056),
    ),
    "l_shoulder_3": LinkInertial(
        mass=0.35913,
        com_xyz=(0.026798412222098958, -1.5999862032697876e-05, 0.014695680617748619),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.00014245, -2.22441e-07, -4.95846e-05, 0.000197807, 1.07538e-07, 0.000151706),
    ),
    "l_upper_arm": LinkInertial(
        mass=0.713864,
        com_xyz=(-0.0031401005252317364, -0.0005800001394788146, 0.030014099942354502),
        com_rpy=(0.0, -1.308996989468287, -3.141592653589725),
        inertia=(0.000455006, -9.1018e-07, -3.2008e-05, 0.000615652, 1.30798e-05, 0.000613922),
    ),
    "l_upper_leg": LinkInertial(
        mass=2.1684,
        com_xyz=(0.0033868999999999913, 0.00010179999999998524, -0.07891600000000001),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(
            0.007776127407181794,
            -0.00014893806511719572,
            -4.765101225034601e-06,
            0.001753647693486041,
            -0.00016405457894194634,
            0.0077654145346884125,
        ),
    ),
    "neck_1": LinkInertial(
        mass=0.125793,
        com_xyz=(7.056099073600001e-05, 0.006567179874003043, -0.0063841545840063706),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(4.0647e-05, 8.09156e-08, -3.74998e-08, 3.881e-05, 9.39717e-06, 4.7535e-05),
    ),
    "neck_2": LinkInertial(
        mass=0.177087,
        com_xyz=(-8.8573009263e-05, 0.03522507508312622, -0.019545227247699644),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000117943, -5.25591e-07, 4.68307e-07, 4.04013e-05, 9.81476e-06, 0.000105186),
    ),
    "r_ankle_2": LinkInertial(
        mass=0.265122,
        com_xyz=(0.0011445999999999956, 3.599999999992498e-06, -0.03852),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(0.000327222, -4.74606e-08, 4.94571e-08, 0.000248285, -4.29975e-06, 0.000150937),
    ),
    "r_elbow_1": LinkInertial(
        mass=0.861052,
        com_xyz=(-0.08876477556662593, 0.01573100000000001, 0.018228219831254368),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000794233, -0.00099896, -0.00139429, -0.00294171, 7.74756e-05, -0.00224312),
    ),
    "r_hip_3": LinkInertial(
        mass=0.126212,
        com_xyz=(-0.00012300000000000505, -0.0002822999999999992, 0.008718000000000031),
        com_rpy=(-1.5707963267948961, 0.0, -1.5707963267948961),
        inertia=(3.27938e-05, 2.67901e-07, -4.41463e-09, 5.69957e-05, 3.32338e-08, 3.26449e-05),
    ),
    "r_lower_leg": LinkInertial(
        mass=1.832,
        com_xyz=(0.0012363999999999917, -0.003513100000000033, -0.08879400000000004),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(
            0.005276871486541036,
            0.0002847746287365357,
            -6.915382566020098e-05,
            0.001892922008115745,
            -0.0003287307187320742,
            0.005692125857783254,
        ),
    ),
    "r_shoulder_1": LinkInertial(
        mass=0.114862,
        com_xyz=(-0.012266467438645498, 3.200000000000425e-05, -0.0032101429043969038),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(2.24541e-05, -1.65173e-08, -3.55626e-06, 2.29582e-05, -6.13337e-08, 1.00116e-05),
    ),
    "r_shoulder_2": LinkInertial(
        mass=0.238162,
        com_xyz=(-0.021414170943809915, 0.00027172527255132917, -0.019440234453461297),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000158626, -1.12091e-07, 1.02574e-05, 0.000206526, 1.19785e-06, 0.000104956),
    ),
    "r_shoulder_3": LinkInertial(
        mass=0.35913,
        com_xyz=(-0.02676207668711196, -6.999999999979245e-06, 0.014699920771321831),
        com_rpy=(0.0, 0.0, 0.0),
        inertia=(0.000142333, 3.60361e-07, 4.94445e-05, 0.000197746, 2.65919e-07, 0.000151821),
    ),
    "r_upper_arm": LinkInertial(
        mass=0.713703,
        com_xyz=(-0.003128599999999997, 0.0005970000000000003, 0.03000619999999999),
        com_rpy=(0.0, 1.30899700696774, 0.0),
        inertia=(0.000454597, -9.33213e-08, 3.20152e-05, 0.000614158, 1.14372e-05, 0.000612647),
    ),
    "r_upper_leg": LinkInertial(
        mass=2.1635,
        com_xyz=(0.0033999999999999933, -2.9100000000018e-05, -0.078954),
        com_rpy=(1.5707963267948961, 0.0, 1.5707963267948961),
        inertia=(
            0.0077705029312875665,
            0.00015544502130009113,
            6.5763333655041776e-06,
            0.001750687934586949,
            -0.00016388268004075972,
            0.0077581397411668595,
        ),
    ),
}
ADDED_LINKS = {
    "chest_l_jet_turbine": AddedLink(
        joint="l_jet_turbine",
        parent="chest",
        xyz=(0.17000000019073502, -0.1141002, -0.1158885),
        rpy=(1.5707963294190819, 1.3264512049591715, 0.0),
        inertial=LinkInertial(
            mass=1.91345,
            com_xyz=(-8.222821810735526e-05, 1.3286115668337262e-05, -0.16112289999999777),
            com_rpy=(-1.570796323266697, 0.0, -2.199114262384067),
            inertia=(0.00734206, -2.05268e-06, 8.57819e-06, 0.00348075, 1.1913e-05, 0.00733956),
        ),
    ),
    "chest_r_jet_turbine": AddedLink(
        joint="r_jet_turbine",
        parent="chest",
        xyz=(-0.169999999809265, -0.1141002, -0.1158885),
        rpy=(-1.5707963207923916, -0.9424794397774846, -3.1415926514080383),
        inertial=LinkInertial(
            mass=1.91345,
            com_xyz=(-8.301234271822916e-05, 1.3339860152949967e-05, -0.16112289999999718),
            com_rpy=(-1.5707963232667206, 0.0, -2.199113213812309),
            inertia=(0.00734206, -2.05268e-06, 8.57819e-06, 0.00348075, 1.1913e-05, 0.00733956),
        ),
    ),
    "l_arm_jet_turbine": AddedLink(
        joint="l_elbow_turbine",
        parent="l_elbow_1",
        xyz=(0.2573114390680438, 0.05361200127217572, 0.09741646799861207),
        rpy=(-1.2854912394964515, 0.4037589814842587, -1.4560685752339375),
        inertial=LinkInertial(
            mass=1.69792,
            com_xyz=(-2.0694917527402934e-05, -9.56549474579807e-05, -0.14371699999823054),
            com_rpy=(-1.5066317990385903e-06, 1.3089971979456438, 1.2042754137722869),
            inertia=(0.00281351, 2.1023e-06, 0.00117334, 0.00717095, 1.7863e-06, 0.00684162),
        ),
    ),
    "r_arm_jet_turbine": AddedLink(
        joint="r_elbow_turbine",
        parent="r_elbow_1",
        xyz=(-0.25731143930868927, 0.07362600000000007, 0.09741646806310904),
        rpy=(1.291296957309416, -0.3534717274196087, -1.4717699551817651),
        inertial=LinkInertial(
            mass=1.69792,
            com_xyz=(-2.0650259469651155e-05, -9.565215182807951e-05, -0.14371700000042664),
            com_rpy=(0.0, 1.3089970025555984, 1.2042770543747778),
            inertia=(0.00281351, 2.1023e-06, 0.00117334, 0.00717095, 1.7863e-06, 0.00684162),
        ),
    ),
    "chest_aruco_origin": AddedLink(
        joint="chest_aruco_joint",
        parent="chest",
        xyz=(-0.088999999809265, -0.03977120000000001, -0.2288885),
        rpy=(3.141592653589793, 0.0, 1.5707963267948966),
        inertial=LinkInertial(
            mass=0.21233,
            com_xyz=(0.1027942, 0.088999999809283, -0.005093999999999987),
            com_rpy=(3.141592653589793, 0.0, 1.5707963267948966),
            inertia=(0.000723088, 0.0, 0.0, 0.000531198, -3.22413e-05, 0.00123444),
        ),
    ),
    "l_sole_1": AddedLink(
        joint="l_sole_1_fixed_joint",
        parent="l_foot",
        xyz=(0.09, -0.0357538, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "l_sole_2": AddedLink(
        joint="l_sole_2_fixed_joint",
        parent="l_foot",
        xyz=(0.08999999999999997, 0.023013700000000005, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "l_sole_3": AddedLink(
        joint="l_sole_3_fixed_joint",
        parent="l_foot",
        xyz=(-0.03600000000000001, 0.023013700000000005, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "l_sole_4": AddedLink(
        joint="l_sole_4_fixed_joint",
        parent="l_foot",
        xyz=(-0.036, -0.0357538, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "r_sole_1": AddedLink(
        joint="r_sole_1_fixed_joint",
        parent="r_foot",
        xyz=(0.08978559999999997, 0.03413489999999998, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "r_sole_2": AddedLink(
        joint="r_sole_2_fixed_joint",
        parent="r_foot",
        xyz=(0.0897856, -0.023675099999999998, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "r_sole_3": AddedLink(
        joint="r_sole_3_fixed_joint",
        parent="r_foot",
        xyz=(-0.03905869999999999, -0.023675099999999998, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
    "r_sole_4": AddedLink(
        joint="r_sole_4_fixed_joint",
        parent="r_foot",
        xyz=(-0.0390587, 0.03413489999999998, 0.014500000000000068),
        rpy=(-3.141592653589793, 0.0, 0.0),
        inertial=None,
    ),
}

for _side in ("l", "r"):
    _bad = LINK_INERTIALS[f"{_side}_elbow_1"]
    LINK_INERTIALS[f"{_side}_elbow_1"] = LinkInertial(
        _bad.mass, _bad.com_xyz, _bad.com_rpy, box_inertia(_bad.mass, ELBOW_MOUNT_BOX)
    )

# Links of iCubGazeboV2_5 that iRonCub does not have: the forearms (and wrists, hands below them).
REMOVED_SUBTREES = ("l_forearm", "r_forearm")

# The jets' meshes are not public: each jet is drawn as a cylinder from the nozzle (frame origin)
# along -z, the direction of thrust; approximate size of a JetCat P250 class engine [m].
JET_LENGTH = 0.35
JET_RADIUS = 0.065
