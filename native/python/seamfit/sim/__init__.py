"""Quasistatic garment simulation (Wang 2018, section 4): Sim_phi(theta).

``Simulator(mesh, sdf, fabric, settings).drape()`` dresses a sewn mesh on a body
given as a signed distance field and returns a ``DrapeResult``. The simulator also
exposes what the pattern optimizer's adjoint needs: the force f(p, x), the
tangent stiffness (exact and PSD-projected Hessian) and (df/dp)^T lambda.
"""
from .model import DrapeResult, Fabric, SimSettings, Simulator
from .dressing import initial_positions
from .multilevel import drape_coarse_to_fine
from .render import render_drape

__all__ = ["DrapeResult", "Fabric", "SimSettings", "Simulator", "drape_coarse_to_fine", "initial_positions", "render_drape"]
