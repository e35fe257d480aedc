"""Geometry computed from a scene spec: pure functions shared by the generator, the
validator, the exporters and the runner (terrain heights, tile meshes)."""
