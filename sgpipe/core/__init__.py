"""SG / vMF / SH math core (no sgpipe imports)."""
from .sg import *  # noqa
