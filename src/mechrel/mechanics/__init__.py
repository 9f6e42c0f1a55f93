"""mechrel.mechanics"""
