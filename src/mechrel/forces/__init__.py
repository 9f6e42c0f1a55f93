"""mechrel.forces"""
