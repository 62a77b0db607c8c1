"""Swappable numerical methods used by the spaces (ODE integration, shooting, optimisation)."""

from .geodesic_ode import GeodesicDomainError, GeodesicIntegrator, GeodesicSolution
from .shooting import ShootingSolver

__all__ = ["GeodesicDomainError", "GeodesicIntegrator", "GeodesicSolution", "ShootingSolver"]
