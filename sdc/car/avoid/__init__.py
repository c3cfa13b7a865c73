"""The avoid-then-return controller (``avoid``) and its parts, one job each
(:mod:`sdc.car.avoid.controller` composes them)."""
