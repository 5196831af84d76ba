"""Centroidal trajectory optimisation with contacts and jets, CasADi + IPOPT."""
