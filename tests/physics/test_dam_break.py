"""Dam break against Martin & Moyce (1952): a water column of width a and height 2 a (n^2 = 2)
collapses along a tank at the default settings; the surge front z (from the back wall) over
time follows the measurements within 10 %, z / a against T = t sqrt(2 g / a)."""
import math

import numpy as np

import cressim

from .particle_scenes import lattice, positions, start, static, step

# Martin, J. C. & Moyce, W. J. (1952), Part IV. An experimental study of the collapse of liquid
# columns on a rigid horizontal plane, Phil. Trans. R. Soc. Lond. A 244, 312-324: Fig. 3, n^2 = 2,
# a = 2.25 in (as digitised for PySPH's dam-break validation). Up to Z = 4.1; the tank ends at 5 a.
T_REF = np.array([0.832, 1.219, 1.997, 2.547, 3.345])
Z_REF = np.array([1.217, 1.474, 2.292, 2.995, 4.134])


def test_dam_break_front_follows_martin_and_moyce(make_engine):
    # a quasi-2D slab: 10 x 4 x 20 particles (r 1 cm, a = 0.2 m) between walls 8 cm apart
    r, cells, slab = 0.01, 10, 4
    a, depth, w = 2 * r * cells, 2 * r * slab, 0.05
    length = 5 * a
    world = cressim.World(cressim.SceneLayout(1))
    static(world, 0, [cressim.Shape.plane(),
                      cressim.Shape.box((w, depth / 2 + w, a), position=(-w, 0, a)),  # back wall at x = 0
                      cressim.Shape.box((w, depth / 2 + w, a), position=(length + w, 0, a)),
                      cressim.Shape.box((length / 2, w, a), position=(length / 2, depth / 2 + w, a)),
                      cressim.Shape.box((length / 2, w, a), position=(length / 2, -depth / 2 - w, a))], "tank")
    column = lattice((cells, slab, 2 * cells), 2 * r, (r, -depth / 2 + r, r))
    world.create_entity(env=0, name="water").add(cressim.Fluid(column, radius=r))
    engine = start(world, make_engine)
    scale = math.sqrt(2 * 9.81 / a)
    T, Z = [0.0], [1.0]
    while T[-1] < T_REF[-1]:
        step(engine, 1)
        T.append(T[-1] + engine.physics.dt * scale)
        Z.append((positions(engine)[:, 0].max() + r) / a)
    error = np.interp(T_REF, T, Z) / Z_REF - 1
    # measured +6.5, +6.6, +1.3, +0.6, -3.5 % (ahead early on: the experiment's gate took time to lift)
    assert np.abs(error).max() < 0.10, error
