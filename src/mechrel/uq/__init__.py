"""mechrel.uq"""
