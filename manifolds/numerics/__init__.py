"""Swappable numerical methods used by the spaces (ODE integration, shooting, optimisation)."""
