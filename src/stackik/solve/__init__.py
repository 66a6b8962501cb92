"""solve_ik and solve_many (being moved here from stackik.ik)."""

from stackik.ik import solve_ik, solve_many

__all__ = ["solve_ik", "solve_many"]
