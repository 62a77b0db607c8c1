"""Swappable numerical methods used by the spaces (ODE integration, shooting, optimisation).

Optimisers live in :mod:`.solvers`, selected by name.
"""

from .geodesic_ode import GeodesicDomainError, GeodesicIntegrator, GeodesicSolution
from .integrators import RK2, RK4, Euler, Integrator, get_integrator
from .shooting import ShootingSolver
from .solvers import SOLVERS, OptimizationResult, StoppingRule, get_solver, minimize_lbfgsb

__all__ = [
    "GeodesicDomainError",
    "GeodesicIntegrator",
    "GeodesicSolution",
    "ShootingSolver",
    "Integrator",
    "Euler",
    "RK2",
    "RK4",
    "get_integrator",
    "SOLVERS",
    "get_solver",
    "OptimizationResult",
    "StoppingRule",
    "minimize_lbfgsb",
]
