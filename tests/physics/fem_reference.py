"""The independent reference for elastic soft bodies: scikit-fem (a finite element library)
solving static linear elasticity under gravity on the same tet mesh, with P1 (linear) tets as the
engine's or P2 (quadratic) ones as the converged answer. Small-strain scenes only: at the strains
the tests use (about 1 %) the engine's Neo-Hookean material is linear elasticity to well within
their tolerance."""
import numpy as np
from skfem import Basis, ElementTetP1, ElementTetP2, ElementVector, LinearForm, MeshTet, condense, solve
from skfem.models.elasticity import lame_parameters, linear_elasticity


def static_displacement(points, tets, clamped, youngs_modulus, poisson_ratio, density, gravity=(0.0, 0.0, -9.81),
                        quadratic=False, sliding=False, point_loads=None):
    """(n, 3) displacement of every mesh vertex at static equilibrium under the body's weight and
    `point_loads` ((n, 3) N on the vertices, or None);
    `clamped(x)` ((3, m) points -> m bools) selects the boundary facets held in place: wholly, or
    with `sliding` only in z (a frictionless floor; the mesh's bottom centre vertex is then held
    in x and y and one vertex on its +x axis in y, which removes the rigid motions the floor
    leaves without loading anything, the body and its load being symmetric)."""
    mesh = MeshTet(np.asarray(points, dtype=np.float64).T, np.asarray(tets, dtype=np.int64).T)
    basis = Basis(mesh, ElementVector(ElementTetP2() if quadratic else ElementTetP1()))
    K = linear_elasticity(*lame_parameters(youngs_modulus, poisson_ratio)).assemble(basis)
    g = np.asarray(gravity, dtype=np.float64) * density

    @LinearForm
    def weight(v, _):
        return g[0] * v[0] + g[1] * v[1] + g[2] * v[2]

    f = weight.assemble(basis)
    if point_loads is not None:
        f[basis.nodal_dofs] += np.asarray(point_loads, dtype=np.float64).T
    held = basis.get_dofs(clamped)
    if sliding:
        p = mesh.p.T
        base = (np.abs(p[:, 0]) < 1e-9) & (np.abs(p[:, 1]) < 1e-9) & clamped(p.T)
        axis = (p[:, 0] > 1e-9) & (np.abs(p[:, 1]) < 1e-9) & clamped(p.T)
        c, a = np.nonzero(base)[0][0], np.nonzero(axis)[0][0]
        nodal = basis.nodal_dofs
        D = np.concatenate([held.all("u^3"), [nodal[0, c], nodal[1, c], nodal[1, a]]])
    else:
        D = held.all()
    u = solve(*condense(K, f, D=D))
    # the vertex dofs, x y z per vertex (the nodal dofs come first, interleaved by component)
    return u[basis.nodal_dofs].T.copy()

