#!/usr/bin/python3
"""Reference Student-t and normal quantiles for tests/test_uncertainty.cpp (scipy)."""
from scipy import stats

for nu in (5, 10, 30, 100):
    print(f"t.ppf(0.975, {nu}) = {stats.t.ppf(0.975, nu):.9f}")
print(f"t.ppf(0.95, 20) = {stats.t.ppf(0.95, 20):.9f}")
print(f"norm.ppf(0.975) = {stats.norm.ppf(0.975):.12f}")
print(f"norm.ppf(0.995) = {stats.norm.ppf(0.995):.12f}")
