"""mechrel.integrate"""
