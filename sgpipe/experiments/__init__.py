"""Experiments that reproduce the papers' figures through the real stages (`make figures`)."""
