"""Swappable numerical methods used by the spaces (ODE integration, shooting, optimisation)."""

from .geodesic_ode import GeodesicDomainError, GeodesicIntegrator, GeodesicSolution
from .integrators import RK2, RK4, Euler, Integrator, get_integrator
from .optimizers import LBFGSOptions, minimize_lbfgsb
from .shooting import ShootingSolver

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
    "LBFGSOptions",
    "minimize_lbfgsb",
]
