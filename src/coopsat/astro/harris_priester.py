"""The Harris–Priester atmosphere: a diurnal bulge between tabulated minimum and maximum
density profiles, with tables for ten levels of solar flux (SPEC §5).

Montenbruck & Gill, *Satellite Orbits* (2000), §3.5.2: at a height h between two tabulated
heights each of the two profiles, ρ_m (the bulge's antapex) and ρ_M (its apex), is interpolated
exponentially, and the density is ``ρ = ρ_m(h) + (ρ_M(h) − ρ_m(h)) cos^n(ψ/2)``, ψ the angle
between the position and the apex of the bulge, which lags the Sun by 30° in right ascension.

Tables
------
:data:`HARRIS_PRIESTER_TABLES` holds the ten tables of the 1964 Harris–Priester (min–max)
atmosphere of NASA Goddard's Trajectory Determination System, F10.7 = 65, 75, 100, …, 275,
59 heights from 110 to 2000 km (the model of Long et al., *Goddard Trajectory Determination
System (GTDS) Mathematical Theory*, Rev. 1, 1989, §4.3). The numbers are those of GTDS's
permanent density file ``atmosden.pc`` (data management report "TRAMP version GNCC 2.1",
2002-05-15, pages 39–48), as shipped with NASA Goddard's Java Astrodynamics Toolkit (JAT,
NASA Open Source Agreement 1.3), ``data/core/forces/harrispriester/harrispriester.txt``
("Harris-Priester data taken from GTDS", 2005-07-21; copy read: github.com/zhufengGNSS/
jat_nasa_java, commit f58e4bd2, blob 29b662a9), printed there in kg/km³ and copied here
digit for digit. Between two levels :func:`harris_priester_table` interpolates log-linearly
in F10.7: that is our interpolation, not a GTDS table.

:data:`MONTENBRUCK_GILL_TABLE_3_8` is M&G's Table 3.8 (mean solar activity, 100–1000 km,
g/km³ in the book), copied from brahe 1.8's source: the table brahe uses. Up to 800 km it is
the GTDS F10.7 = 150 table: the two agree at all 44 heights they share from 120 to 800 km;
M&G has 100 km and 840–960 km instead of 110 km and 850–950 km, and differs at 1000 km
(1.150e-3/1.810e-2 against 1.9e-3/1.7e-2 g/km³).

Not shipped: Harris & Priester's original tables (J. Atmos. Sci. 19, 1962), for want of a
citable machine-readable copy. Long et al.'s printed pages were not at hand either: the GTDS
numbers rest on GTDS's own file, checked against M&G at F10.7 = 150.

Height
------
The height is the one brahe 1.8 uses (``density_harris_priester``, after M&G's reference
code): the height above the WGS-84 ellipsoid (a = 6378137 m, f = 1/298.257223563) along its
normal, of the position taken as Earth-fixed. An inertial or true-of-date position gives the
same height, which depends only on ``z`` and ``x² + y²``. ``jax.numpy``: traces under ``jit``.
"""

import math

import jax.numpy as jnp
import numpy as np

from coopsat.astro.earth import WGS84_A_M, WGS84_E2

# GTDS atmosden.pc (via JAT, see the module notes): the heights of all ten tables (km), and for
# each F10.7 level the minimum and maximum densities there (kg/km³ = 1e-9 kg/m³), as printed.
_GTDS_HEIGHTS_KM = (
    110.0, 120.0, 130.0, 140.0, 150.0, 160.0, 170.0, 180.0, 190.0, 200.0, 210.0, 220.0, 230.0, 240.0, 250.0, 260.0,
    270.0, 280.0, 290.0, 300.0, 320.0, 340.0, 360.0, 380.0, 400.0, 420.0, 440.0, 460.0, 480.0, 500.0, 520.0, 540.0,
    560.0, 580.0, 600.0, 620.0, 640.0, 660.0, 680.0, 700.0, 720.0, 740.0, 760.0, 780.0, 800.0, 850.0, 900.0, 950.0,
    1000.0, 1100.0, 1200.0, 1300.0, 1400.0, 1500.0, 1600.0, 1700.0, 1800.0, 1900.0, 2000.0,
)
_GTDS_KG_KM3 = {
    65: (
        (
            78.0, 24.9, 8.978, 4.069, 2.086, 1.146, 0.6616, 0.4016, 0.253, 0.1628, 0.1076, 0.07287, 0.05038, 0.03549,
            0.02541, 0.01846, 0.01358, 0.0101, 0.007588, 0.005719, 0.003305, 0.001953, 0.001175, 0.0007167, 0.0004428,
            0.0002779, 0.000176, 0.0001128, 7.346e-05, 4.866e-05, 3.291e-05, 2.279e-05, 1.622e-05, 1.188e-05,
            8.978e-06, 6.987e-06, 5.593e-06, 4.589e-06, 3.846e-06, 3.281e-06, 2.838e-06, 2.482e-06, 2.19e-06,
            1.944e-06, 1.736e-06, 1.18e-06, 8.7e-07, 6.6e-07, 4.8e-07, 3e-07, 1.85e-07, 1.13e-07, 7.3e-08, 5.2e-08,
            3.7e-08, 2.55e-08, 1.82e-08, 1.3e-08, 1e-08,
        ),
        (
            78.0, 24.9, 9.331, 4.212, 2.168, 1.236, 0.7558, 0.4885, 0.3274, 0.2284, 0.1634, 0.1192, 0.08851, 0.06666,
            0.05083, 0.03919, 0.0305, 0.02394, 0.01894, 0.0151, 0.009886, 0.006608, 0.004494, 0.0031, 0.002163,
            0.001526, 0.001085, 0.0007767, 0.0005599, 0.0004061, 0.0002963, 0.0002174, 0.0001605, 0.0001192, 8.91e-05,
            6.708e-05, 5.09e-05, 3.896e-05, 3.011e-05, 2.351e-05, 1.857e-05, 1.484e-05, 1.202e-05, 9.857e-06,
            8.193e-06, 6.2e-06, 4.4e-06, 3.3e-06, 2.7e-06, 1.75e-06, 1.2e-06, 8.5e-07, 6.2e-07, 4.75e-07, 3.65e-07,
            3e-07, 2.2e-07, 1.8e-07, 1.45e-07,
        ),
    ),
    75: (
        (
            78.0, 24.9, 8.913, 4.051, 2.092, 1.16, 0.6781, 0.4157, 0.2653, 0.1725, 0.1151, 0.07866, 0.05485, 0.03894,
            0.0281, 0.02056, 0.01523, 0.01141, 0.008631, 0.006554, 0.00384, 0.002301, 0.001403, 0.0008684, 0.000544,
            0.0003419, 0.0002189, 0.0001418, 9.304e-05, 6.194e-05, 4.195e-05, 2.899e-05, 2.05e-05, 1.487e-05,
            1.109e-05, 8.5e-06, 6.699e-06, 5.416e-06, 4.479e-06, 3.777e-06, 3.238e-06, 2.812e-06, 2.468e-06,
            2.184e-06, 1.945e-06, 1.4e-06, 1e-06, 7.8e-07, 5.8e-07, 3.55e-07, 2.3e-07, 1.45e-07, 9.1e-08, 6.7e-08,
            4.5e-08, 3.3e-08, 2.25e-08, 1.6e-08, 1.28e-08,
        ),
        (
            78.0, 24.9, 9.263, 4.197, 2.176, 1.249, 0.7697, 0.5016, 0.3391, 0.2381, 0.1716, 0.1262, 0.09435, 0.07155,
            0.05492, 0.04261, 0.03337, 0.02635, 0.02096, 0.01682, 0.01113, 0.007514, 0.00516, 0.003595, 0.002534,
            0.001798, 0.001291, 0.0009334, 0.0006795, 0.0004976, 0.0003664, 0.0002713, 0.0002019, 0.0001511,
            0.0001137, 8.614e-05, 6.567e-05, 5.043e-05, 3.903e-05, 3.047e-05, 2.402e-05, 1.913e-05, 1.54e-05,
            1.254e-05, 1.033e-05, 7.3e-06, 5.2e-06, 3.8e-06, 3.1e-06, 2.05e-06, 1.4e-06, 1e-06, 7.2e-07, 5.45e-07,
            4.15e-07, 3.4e-07, 2.65e-07, 2.1e-07, 1.7e-07,
        ),
    ),
    100: (
        (
            78.0, 24.9, 8.74, 4.002, 2.103, 1.195, 0.7186, 0.4515, 0.2957, 0.198, 0.1354, 0.09459, 0.06737, 0.0488,
            0.03589, 0.02675, 0.02017, 0.01538, 0.01183, 0.009117, 0.005522, 0.003421, 0.002158, 0.001382, 0.0008952,
            0.0005863, 0.0003875, 0.0002584, 0.0001739, 0.0001182, 8.123e-05, 5.65e-05, 3.987e-05, 2.859e-05,
            2.088e-05, 1.556e-05, 1.185e-05, 9.23e-06, 7.351e-06, 5.982e-06, 4.965e-06, 4.195e-06, 3.6e-06, 3.13e-06,
            2.751e-06, 2e-06, 1.5e-06, 1.2e-06, 9.4e-07, 5.8e-07, 3.75e-07, 2.5e-07, 1.7e-07, 1.18e-07, 8.2e-08,
            6e-08, 4.3e-08, 3.2e-08, 2.4e-08,
        ),
        (
            78.0, 24.9, 9.091, 4.157, 2.191, 1.283, 0.8069, 0.5353, 0.3695, 0.2638, 0.1938, 0.1452, 0.1105, 0.08527,
            0.06657, 0.0525, 0.04177, 0.03349, 0.02705, 0.02202, 0.01496, 0.01036, 0.007298, 0.00521, 0.003763,
            0.002744, 0.002019, 0.001497, 0.001117, 0.0008382, 0.0006324, 0.0004794, 0.0003651, 0.0002793, 0.0002146,
            0.0001656, 0.0001284, 0.0001, 7.83e-05, 6.162e-05, 4.879e-05, 3.886e-05, 3.117e-05, 2.518e-05, 2.05e-05,
            1.3e-05, 9e-06, 6.2e-06, 5e-06, 3.1e-06, 2.1e-06, 1.5e-06, 1.1e-06, 7.7e-07, 6e-07, 5e-07, 3.9e-07,
            3.1e-07, 2.5e-07,
        ),
    ),
    125: (
        (
            78.0, 24.9, 8.567, 3.952, 2.111, 1.226, 0.7572, 0.4864, 0.3255, 0.2243, 0.1567, 0.1118, 0.08115, 0.05987,
            0.04479, 0.03394, 0.026, 0.02011, 0.0157, 0.01231, 0.007675, 0.004894, 0.003178, 0.002094, 0.001397,
            0.0009625, 0.0006552, 0.0004497, 0.0003109, 0.0002166, 0.000152, 0.0001076, 7.685e-05, 5.545e-05,
            4.047e-05, 2.992e-05, 2.244e-05, 1.71e-05, 1.325e-05, 1.045e-05, 8.397e-06, 6.867e-06, 5.713e-06,
            4.83e-06, 4.143e-06, 3.15e-06, 2.25e-06, 1.72e-06, 1.4e-06, 8.5e-07, 5.4e-07, 3.8e-07, 2.8e-07, 1.95e-07,
            1.35e-07, 1.02e-07, 7.4e-08, 5.6e-08, 4.4e-08,
        ),
        (
            78.0, 24.9, 8.92, 4.113, 2.202, 1.314, 0.8411, 0.5672, 0.3989, 0.2889, 0.2159, 0.1644, 0.1272, 0.09978,
            0.07913, 0.06336, 0.05116, 0.04163, 0.03409, 0.02809, 0.01953, 0.01385, 0.009976, 0.007282, 0.005376,
            0.004033, 0.003034, 0.002299, 0.001754, 0.001346, 0.001038, 0.0008043, 0.000626, 0.0004892, 0.0003838,
            0.0003022, 0.0002388, 0.0001894, 0.0001507, 0.0001204, 9.658e-05, 7.777e-05, 6.289e-05, 5.109e-05,
            4.17e-05, 2.7e-05, 1.8e-05, 1.2e-05, 8.8e-06, 5.3e-06, 3.2e-06, 2.25e-06, 1.5e-06, 1.03e-06, 8e-07,
            6.5e-07, 5.2e-07, 4.25e-07, 3.4e-07,
        ),
    ),
    150: (
        (
            78.0, 24.9, 8.377, 3.899, 2.122, 1.263, 0.8008, 0.5283, 0.3617, 0.2557, 0.1839, 0.1341, 0.09949, 0.07488,
            0.05709, 0.04403, 0.0343, 0.02697, 0.02139, 0.01708, 0.01099, 0.007214, 0.004824, 0.003274, 0.002249,
            0.001558, 0.001091, 0.0007701, 0.0005474, 0.0003916, 0.0002819, 0.0002042, 0.0001488, 0.0001092, 8.07e-05,
            6.012e-05, 4.519e-05, 3.43e-05, 2.632e-05, 2.043e-05, 1.607e-05, 1.281e-05, 1.036e-05, 8.496e-06,
            7.069e-06, 4.8e-06, 3.3e-06, 2.45e-06, 1.9e-06, 1.18e-06, 7.5e-07, 5.3e-07, 4.1e-07, 2.9e-07, 2e-07,
            1.6e-07, 1.2e-07, 9.6e-08, 7.3e-08,
        ),
        (
            78.0, 24.9, 8.71, 4.059, 2.215, 1.344, 0.8758, 0.601, 0.4297, 0.3162, 0.2396, 0.1853, 0.1455, 0.1157,
            0.09308, 0.07555, 0.06182, 0.05095, 0.04226, 0.03526, 0.02511, 0.01819, 0.01337, 0.009955, 0.007492,
            0.005684, 0.004355, 0.003362, 0.002612, 0.002042, 0.001605, 0.001267, 0.001005, 0.0007997, 0.000639,
            0.0005123, 0.0004121, 0.0003325, 0.0002691, 0.0002185, 0.0001779, 0.0001452, 0.000119, 9.776e-05,
            8.059e-05, 5.5e-05, 3.7e-05, 2.4e-05, 1.7e-05, 8.7e-06, 4.8e-06, 3.2e-06, 2e-06, 1.35e-06, 9.5e-07,
            7.7e-07, 6.3e-07, 5.2e-07, 4.4e-07,
        ),
    ),
    175: (
        (
            78.0, 24.9, 8.239, 3.858, 2.123, 1.283, 0.8246, 0.5538, 0.3848, 0.276, 0.2019, 0.1495, 0.1124, 0.08579,
            0.06626, 0.05174, 0.04079, 0.03244, 0.026, 0.02087, 0.01368, 0.009157, 0.006238, 0.004313, 0.003019,
            0.002134, 0.001523, 0.001096, 0.0007934, 0.0005782, 0.0004237, 0.0003122, 0.0002313, 0.0001723, 0.000129,
            9.724e-05, 7.374e-05, 5.631e-05, 4.334e-05, 3.363e-05, 2.634e-05, 2.084e-05, 1.666e-05, 1.347e-05,
            1.103e-05, 7.8e-06, 5.1e-06, 3.45e-06, 2.6e-06, 1.6e-06, 1e-06, 7e-07, 5.43e-07, 4e-07, 2.9e-07, 2.3e-07,
            1.75e-07, 1.4e-07, 1.09e-07,
        ),
        (
            78.0, 24.9, 8.577, 4.021, 2.218, 1.363, 0.8997, 0.6251, 0.4514, 0.3362, 0.2569, 0.2008, 0.1593, 0.128,
            0.104, 0.08522, 0.07041, 0.05858, 0.04904, 0.04131, 0.02991, 0.02201, 0.01643, 0.01241, 0.009475,
            0.007293, 0.005665, 0.004433, 0.003491, 0.002766, 0.002203, 0.001763, 0.001417, 0.001143, 0.0009258,
            0.0007523, 0.0006133, 0.0005014, 0.0004111, 0.000338, 0.0002787, 0.0002303, 0.0001908, 0.0001585,
            0.000132, 9.2e-05, 6.3e-05, 4.1e-05, 2.85e-05, 1.4e-05, 7.4e-06, 4.3e-06, 2.6e-06, 1.7e-06, 1.2e-06,
            9.4e-07, 7.4e-07, 6e-07, 5.2e-07,
        ),
    ),
    200: (
        (
            78.0, 24.9, 8.068, 3.811, 2.13, 1.313, 0.8568, 0.5937, 0.4238, 0.31, 0.2297, 0.1732, 0.1326, 0.1029,
            0.08073, 0.06398, 0.05117, 0.04124, 0.03349, 0.02735, 0.01838, 0.0126, 0.008778, 0.006205, 0.004441,
            0.00321, 0.002343, 0.001723, 0.001276, 0.0009506, 0.0007122, 0.0005362, 0.0004057, 0.0003083, 0.0002354,
            0.0001805, 0.000139, 0.0001076, 8.372e-05, 6.549e-05, 5.153e-05, 4.08e-05, 3.253e-05, 2.613e-05,
            2.116e-05, 1.3e-05, 7.9e-06, 5e-06, 3.5e-06, 2.1e-06, 1.3e-06, 9e-07, 6.8e-07, 5e-07, 3.7e-07, 3e-07,
            2.32e-07, 1.82e-07, 1.45e-07,
        ),
        (
            78.0, 24.9, 8.381, 3.964, 2.222, 1.386, 0.9278, 0.6531, 0.4772, 0.3599, 0.2778, 0.2194, 0.1759, 0.1428,
            0.1171, 0.09689, 0.0808, 0.06784, 0.05735, 0.04885, 0.03595, 0.02687, 0.02035, 0.0156, 0.01207, 0.009417,
            0.007411, 0.005874, 0.004686, 0.00376, 0.003033, 0.002458, 0.002001, 0.001635, 0.001341, 0.001104,
            0.0009114, 0.0007547, 0.0006267, 0.0005218, 0.0004355, 0.0003643, 0.0003055, 0.0002567, 0.0002162,
            0.00014, 9.4e-05, 6.4e-05, 4.4e-05, 2.2e-05, 1.1e-05, 6.2e-06, 3.6e-06, 2.25e-06, 1.55e-06, 1.2e-06,
            9e-07, 7.3e-07, 6e-07,
        ),
    ),
    225: (
        (
            78.0, 24.9, 7.956, 3.777, 2.128, 1.324, 0.8782, 0.6119, 0.438, 0.323, 0.2441, 0.1868, 0.1445, 0.1133,
            0.08976, 0.07182, 0.05795, 0.04713, 0.0385, 0.03154, 0.02152, 0.01496, 0.01057, 0.007569, 0.005487,
            0.004014, 0.002967, 0.00221, 0.001657, 0.001251, 0.0009489, 0.0007236, 0.0005543, 0.0004264, 0.0003294,
            0.0002555, 0.0001989, 0.0001555, 0.0001221, 9.631e-05, 7.63e-05, 6.074e-05, 4.862e-05, 3.913e-05,
            3.169e-05, 2e-05, 1.2e-05, 7.7e-06, 5.1e-06, 2.8e-06, 1.68e-06, 1.1e-06, 8.1e-07, 6e-07, 4.5e-07, 3.6e-07,
            2.8e-07, 2.25e-07, 1.78e-07,
        ),
        (
            78.0, 24.9, 8.262, 3.929, 2.221, 1.397, 0.9448, 0.6705, 0.4938, 0.3751, 0.2913, 0.2317, 0.187, 0.1528,
            0.1262, 0.1051, 0.0882, 0.07452, 0.06347, 0.05439, 0.04048, 0.03059, 0.02342, 0.01813, 0.01417, 0.01116,
            0.008863, 0.00709, 0.005707, 0.00462, 0.003759, 0.003074, 0.002524, 0.002081, 0.001722, 0.00143, 0.001191,
            0.000995, 0.0008335, 0.0007, 0.0005893, 0.0004973, 0.0004206, 0.0003564, 0.0003027, 0.0002, 0.000135,
            9.3e-05, 6.8e-05, 3.4e-05, 1.7e-05, 9.4e-06, 5.2e-06, 3.2e-06, 2.2e-06, 1.6e-06, 1.2e-06, 9.1e-07,
            7.2e-07,
        ),
    ),
    250: (
        (
            78.0, 24.9, 7.832, 3.742, 2.13, 1.34, 0.9004, 0.635, 0.4612, 0.344, 0.2627, 0.204, 0.1597, 0.1266, 0.1014,
            0.08196, 0.06679, 0.05482, 0.04508, 0.03727, 0.02586, 0.01827, 0.0131, 0.009519, 0.006997, 0.005191,
            0.003889, 0.002936, 0.002232, 0.001708, 0.001314, 0.001015, 0.0007885, 0.0006149, 0.0004813, 0.0003782,
            0.0002982, 0.000236, 0.0001874, 0.0001494, 0.0001195, 9.595e-05, 7.735e-05, 6.262e-05, 5.092e-05, 3.1e-05,
            1.8e-05, 1.15e-05, 7.6e-06, 3.8e-06, 2.1e-06, 1.32e-06, 9.4e-07, 7e-07, 5.2e-07, 4.1e-07, 3.3e-07,
            2.6e-07, 2.1e-07,
        ),
        (
            78.0, 24.9, 8.121, 3.885, 2.22, 1.41, 0.9624, 0.6889, 0.5119, 0.3904, 0.3064, 0.2451, 0.1991, 0.1638,
            0.136, 0.114, 0.09627, 0.08195, 0.07025, 0.06053, 0.04554, 0.03477, 0.02689, 0.02101, 0.01658, 0.01317,
            0.01056, 0.008518, 0.006915, 0.005645, 0.004631, 0.003818, 0.003161, 0.002627, 0.002192, 0.001835,
            0.001541, 0.001298, 0.001096, 0.0009281, 0.0007878, 0.0006702, 0.0005714, 0.0004881, 0.0004179, 0.00027,
            0.00018, 0.00013, 9.6e-05, 5.1e-05, 2.5e-05, 1.4e-05, 8.1e-06, 5e-06, 3.45e-06, 2.4e-06, 1.62e-06,
            1.2e-06, 9.4e-07,
        ),
    ),
    275: (
        (
            78.0, 24.9, 7.717, 3.71, 2.132, 1.355, 0.9207, 0.6563, 0.4831, 0.3644, 0.2813, 0.221, 0.175, 0.1402,
            0.1135, 0.09274, 0.07613, 0.06279, 0.0521, 0.04346, 0.03067, 0.02201, 0.01602, 0.01181, 0.008804, 0.00662,
            0.005025, 0.003844, 0.002961, 0.002295, 0.001788, 0.0014, 0.001102, 0.0008702, 0.00069, 0.0005491,
            0.0004384, 0.0003512, 0.0002822, 0.0002275, 0.000184, 0.0001492, 0.0001214, 9.912e-05, 8.119e-05, 4.4e-05,
            2.7e-05, 1.7e-05, 1.15e-05, 5.3e-06, 2.65e-06, 1.55e-06, 1.08e-06, 8e-07, 5.8e-07, 4.65e-07, 3.65e-07,
            2.9e-07, 2.3e-07,
        ),
        (
            78.0, 24.9, 7.984, 3.841, 2.215, 1.42, 0.9775, 0.7052, 0.528, 0.4064, 0.3201, 0.2574, 0.2102, 0.1737,
            0.1451, 0.1222, 0.1038, 0.08891, 0.07656, 0.06625, 0.05026, 0.03869, 0.03015, 0.02375, 0.01887, 0.01511,
            0.01219, 0.009906, 0.008091, 0.006654, 0.005497, 0.004561, 0.003801, 0.00318, 0.002671, 0.002251,
            0.001902, 0.001613, 0.001371, 0.001169, 0.0009984, 0.000855, 0.0007338, 0.000631, 0.0005437, 0.000365,
            0.00024, 0.000175, 0.00013, 7.3e-05, 3.8e-05, 2.2e-05, 1.35e-05, 8.4e-06, 5.8e-06, 3.8e-06, 2.4e-06,
            1.7e-06, 1.25e-06,
        ),
    ),
}

# M&G Table 3.8: heights (km) and minimum and maximum densities (g/km³ = 1e-12 kg/m³).
_MG_HEIGHTS_KM = (
    100.0, 120.0, 130.0, 140.0, 150.0, 160.0, 170.0, 180.0, 190.0, 200.0, 210.0, 220.0, 230.0, 240.0, 250.0, 260.0,
    270.0, 280.0, 290.0, 300.0, 320.0, 340.0, 360.0, 380.0, 400.0, 420.0, 440.0, 460.0, 480.0, 500.0, 520.0, 540.0,
    560.0, 580.0, 600.0, 620.0, 640.0, 660.0, 680.0, 700.0, 720.0, 740.0, 760.0, 780.0, 800.0, 840.0, 880.0, 920.0,
    960.0, 1000.0,
)
_MG_MIN_G_KM3 = (
    4.974e5, 2.490e4, 8.377e3, 3.899e3, 2.122e3, 1.263e3, 8.008e2, 5.283e2, 3.617e2, 2.557e2, 1.839e2, 1.341e2,
    9.949e1, 7.488e1, 5.709e1, 4.403e1, 3.430e1, 2.697e1, 2.139e1, 1.708e1, 1.099e1, 7.214, 4.824, 3.274, 2.249,
    1.558, 1.091, 7.701e-1, 5.474e-1, 3.916e-1, 2.819e-1, 2.042e-1, 1.488e-1, 1.092e-1, 8.070e-2, 6.012e-2,
    4.519e-2, 3.430e-2, 2.632e-2, 2.043e-2, 1.607e-2, 1.281e-2, 1.036e-2, 8.496e-3, 7.069e-3, 4.680e-3, 3.200e-3,
    2.210e-3, 1.560e-3, 1.150e-3,
)
_MG_MAX_G_KM3 = (
    4.974e5, 2.490e4, 8.710e3, 4.059e3, 2.215e3, 1.344e3, 8.758e2, 6.010e2, 4.297e2, 3.162e2, 2.396e2, 1.853e2,
    1.455e2, 1.157e2, 9.308e1, 7.555e1, 6.182e1, 5.095e1, 4.226e1, 3.526e1, 2.511e1, 1.819e1, 1.337e1, 9.955,
    7.492, 5.684, 4.355, 3.362, 2.612, 2.042, 1.605, 1.267, 1.005, 7.997e-1, 6.390e-1, 5.123e-1, 4.121e-1,
    3.325e-1, 2.691e-1, 2.185e-1, 1.779e-1, 1.452e-1, 1.190e-1, 9.776e-2, 8.059e-2, 5.741e-2, 4.210e-2, 3.130e-2,
    2.360e-2, 1.810e-2,
)

MONTENBRUCK_GILL_TABLE_3_8 = (
    _MG_HEIGHTS_KM,
    tuple(rho / 1e12 for rho in _MG_MIN_G_KM3),
    tuple(rho / 1e12 for rho in _MG_MAX_G_KM3),
)
"""M&G Table 3.8 (mean solar activity): (heights km, minimum densities kg/m³, maximum densities
kg/m³), 100–1000 km. The table of brahe's Harris–Priester model."""

HARRIS_PRIESTER_TABLES = {
    f107: (_GTDS_HEIGHTS_KM, tuple(rho / 1e9 for rho in minimum), tuple(rho / 1e9 for rho in maximum))
    for f107, (minimum, maximum) in _GTDS_KG_KM3.items()
}
"""F10.7 level (10⁻²² W m⁻² Hz⁻¹) → (heights km, minimum densities kg/m³, maximum densities
kg/m³): GTDS's 1964 Harris–Priester tables (see the module notes), 110–2000 km."""

_LEVELS = tuple(sorted(HARRIS_PRIESTER_TABLES))

_RA_LAG_RAD = 0.523599
"""Lag of the bulge apex behind the Sun in right ascension, rad: M&G's 30° written to six
decimals, as in M&G's reference code and brahe, so that the two agree to rounding. It is
2.2e-7 rad (1.4 m at the Earth's surface) more than π/6."""

_GEODETIC_PASSES = 7
"""Passes of the height iteration. Each shrinks the error about 150-fold (≈ 1/e²): measured from
50 to 2100 km, 7e-7 m after five passes and rounding (5e-9 m) after six; the seventh is margin."""


def harris_priester_table(f107):
    """Harris–Priester table for a solar-flux level (design time, NumPy).

    Parameters
    ----------
    f107 : float
        Mean F10.7 solar flux, 10⁻²² W m⁻² Hz⁻¹, from 65 to 275.

    Returns
    -------
    heights_km, rho_min_kg_m3, rho_max_kg_m3 : ndarray, shape (59,)
        Tabulated heights, km, and the minimum (antapex) and maximum (apex) densities there, kg/m³.

    Raises
    ------
    ValueError
        ``f107`` outside 65–275 (or not a number).

    Notes
    -----
    At a tabulated level (65, 75, 100, 125, …, 275) the GTDS table itself. Between two levels
    each density is interpolated log-linearly in F10.7, ``ln ρ = (1 − w) ln ρ_lo + w ln ρ_hi``,
    ``w = (F − F_lo)/(F_hi − F_lo)``: our interpolation, not a published table. Log-linear
    because the density at a fixed height grows roughly exponentially with the flux (a factor
    of 1.2–1.9 per step at 500 km); the ten tables share their heights, so the result is again
    a table of the same kind.
    """
    f107 = float(f107)
    if not _LEVELS[0] <= f107 <= _LEVELS[-1]:
        raise ValueError(
            f"f107 = {f107:g} is outside the Harris-Priester tables: 65 <= f107 <= 275 "
            f"(levels {', '.join(map(str, _LEVELS))}; interpolated between them)"
        )
    upper = next(level for level in _LEVELS if level >= f107)
    heights, minimum, maximum = (np.asarray(column, dtype=float) for column in HARRIS_PRIESTER_TABLES[upper])
    if upper == f107:
        return heights, minimum, maximum
    lower = _LEVELS[_LEVELS.index(upper) - 1]
    _, minimum_lo, maximum_lo = (np.asarray(column, dtype=float) for column in HARRIS_PRIESTER_TABLES[lower])
    w = (f107 - lower) / (upper - lower)
    return heights, minimum_lo ** (1.0 - w) * minimum**w, maximum_lo ** (1.0 - w) * maximum**w


def density_kg_m3(r_m, r_sun_m, table, n_exponent=2.0, axis=-1):
    """Harris–Priester density, kg/m³.

    Parameters
    ----------
    r_m : array_like, shape (..., 3) (component ``axis``)
        Position relative to the Earth's centre (ECI, true-of-date or ECEF), m.
    r_sun_m : array_like, components on ``axis``, broadcastable against ``r_m``
        Position of the Sun in the same frame as ``r_m`` (``(3, 1)`` for ``r_m`` of ``(3, n)``), m;
        only its direction counts.
    table : (heights_km, rho_min_kg_m3, rho_max_kg_m3)
        From :func:`harris_priester_table`, or :data:`MONTENBRUCK_GILL_TABLE_3_8`; heights increasing.
    n_exponent : float
        ``n`` of ``cos^n(ψ/2)``: M&G give 2 for low inclinations to 6 for polar orbits. brahe's
        fixed ``n_prm = 3`` raises ``cos²(ψ/2)`` to the 3rd power: it is ``n = 6`` here.
    axis : int
        Component axis of ``r_m`` and ``r_sun_m``.

    Returns
    -------
    jax.Array, the shape of ``r_m`` without the component axis
        0.0 at and outside the table's first and last heights (100 and 1000 km for M&G, 110 and
        2000 km for GTDS), as brahe and M&G's code return.

    Notes
    -----
    M&G §3.5.2, eqs. 3.105–3.107. Between tabulated heights ``h_i ≤ h < h_{i+1}`` each profile
    is ``ρ(h) = ρ(h_i) exp((h_i − h)/H_i)`` with ``H_i = (h_i − h_{i+1}) / ln(ρ(h_{i+1})/ρ(h_i))``;
    then ``ρ = ρ_m + (ρ_M − ρ_m) cos^n(ψ/2)`` with ``cos^n(ψ/2) = (1/2 + cos ψ/2)^(n/2)`` and
    ``cos ψ = r̂·ê_b``, ``ê_b`` the Sun's direction turned 30° east about the z axis (right
    ascension + 30°, declination kept). The height is the WGS-84 ellipsoidal height by the
    iteration on ``Δz`` of M&G's reference code and brahe's ``position_ecef_to_geodetic``:
    ``sin φ = (z + Δz)/√(x² + y² + (z + Δz)²)``, ``N = a/√(1 − e² sin²φ)``, ``Δz = N e² sin φ``,
    ``h = √(x² + y² + (z + Δz)²) − N``.
    """
    r_m = jnp.asarray(r_m)
    heights_km, rho_min, rho_max = (jnp.asarray(column) for column in table)
    h_km = _ellipsoidal_height_m(r_m, axis) / 1000.0
    # Section i with h_i <= h < h_{i+1}; clipped so that heights outside still index a section
    # (their value is discarded below) and the traced gather stays in bounds.
    i = jnp.clip(jnp.searchsorted(heights_km, h_km, side="right") - 1, 0, heights_km.shape[0] - 2)

    def profile(rho):
        scale_km = (heights_km[i] - heights_km[i + 1]) / jnp.log(rho[i + 1] / rho[i])
        return rho[i] * jnp.exp((heights_km[i] - h_km) / scale_km)

    d_min, d_max = profile(rho_min), profile(rho_max)
    sun = jnp.asarray(r_sun_m)
    sun = sun / jnp.linalg.norm(sun, axis=axis, keepdims=True)
    sx, sy, sz = (jnp.take(sun, k, axis=axis) for k in range(3))
    rx, ry, rz = (jnp.take(r_m, k, axis=axis) for k in range(3))
    # Turning the Sun's unit vector about z by the lag moves its right ascension and keeps its
    # declination: M&G's apex vector without the arctangents.
    cos_lag, sin_lag = math.cos(_RA_LAG_RAD), math.sin(_RA_LAG_RAD)
    apex_dot_r = (cos_lag * sx - sin_lag * sy) * rx + (sin_lag * sx + cos_lag * sy) * ry + sz * rz
    cos2_half_psi = 0.5 + 0.5 * apex_dot_r / jnp.linalg.norm(r_m, axis=axis)
    # Rounding can push cos ψ a hair below −1 at the antapex; a negative base of a fractional
    # power would be NaN.
    bulge = jnp.maximum(cos2_half_psi, 0.0) ** (0.5 * n_exponent)
    rho = d_min + (d_max - d_min) * bulge
    return jnp.where((h_km > heights_km[0]) & (h_km < heights_km[-1]), rho, 0.0)


def _ellipsoidal_height_m(r_m, axis):
    """Height above the WGS-84 ellipsoid, m, by M&G's iteration (see :func:`density_kg_m3`)."""
    x, y, z = (jnp.take(r_m, k, axis=axis) for k in range(3))
    rho2 = x * x + y * y
    dz = WGS84_E2 * z
    for _ in range(_GEODETIC_PASSES):
        zdz = z + dz
        norm = jnp.sqrt(rho2 + zdz * zdz)
        sin_lat = zdz / norm
        n_m = WGS84_A_M / jnp.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)
        # The height pairs N with the Δz it came from, as brahe does when it stops.
        dz, height = n_m * WGS84_E2 * sin_lat, norm - n_m
    return height
