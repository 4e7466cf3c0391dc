"""coopsat: cooperative control of spacecraft formations.

The package is layered (see docs/architecture.md): geometry and astro at the bottom, then
dynamics, actuators and network, then control and design, then the simulation engine, then
scenarios, analysis, plots and the command line. Importing ``coopsat`` itself is cheap; JAX is
imported by the modules that run compiled code.
"""

__version__ = "0.1.0"
