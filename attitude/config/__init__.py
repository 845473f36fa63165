"""The spacecraft description: a TOML file, its validation, and the dataclasses it reads into.

A spacecraft file (read with the standard library's :mod:`tomllib`) holds
the inertia, the reaction wheels, the gyro, the star tracker, the control
design parameters, an optional orbit (circular, Keplerian or TLE) with its
environment models, surface model, magnetorquers, magnetometer, sun sensors, detumbling
and momentum settings, the Sun direction, the requirements the design must
meet, and an optional Monte Carlo campaign. :func:`load_config`
reads and validates it into a :class:`SpacecraftConfig` (frozen dataclasses
that mirror the file, key for key). :mod:`attitude.app.assembly` turns it
into the toolkit objects (body, wheels, sensors, controllers, estimators).

The subpackage:

* :mod:`attitude.config.schema`: every key with its unit and meaning
  (:data:`CONFIG_KEYS`), :class:`ConfigError`, unit spellings;
* :mod:`attitude.config.model`: the frozen dataclasses and their constants;
* :mod:`attitude.config.reader`: :func:`load_config`, :func:`parse_config`,
  :func:`config_from_dict`, :func:`default_config`;
* :mod:`attitude.config.writer`: :func:`config_to_toml`;
* :mod:`attitude.config.build`: each table as its object in SI, used by the
  reader to validate and by the assembly to build.

Key names carry their units
    Every key that holds a physical quantity ends in its unit (``_kg_m2``,
    ``_Nm``, ``_Nms``, ``_s``, ``_deg``, ``_arcsec``, ``_km``, ``_rad_per_s``,
    ``_deg_per_s``, ``_deg_per_h``, ``_deg_per_sqrt_h``, ``_ppm``,
    ``_percent``, ``_per_s`` ...). Values are bare numbers: the unit is fixed
    by the key name, and a string such as ``"0.05 Nm"`` is an error that says
    so. Keys without a unit are dimensionless (``count``, ``damping``,
    ``runs``, ``seed``), names, or vectors whose suffix names their frame
    (``_B`` body axes, ``_N`` inertial axes); quaternions ``q_BN`` are scalar
    first ``[w, x, y, z]``. Direction vectors and quaternions are stored as
    written and normalised where they are used. The values are converted to
    SI only when the objects are built (DESIGN.md: datasheet units only at
    the edges, in explicitly named keys).

Validation
    Every problem raises :class:`ConfigError` (a :class:`ValueError`) whose
    message is ``"FILE: KEY: problem"``, with ``KEY`` the dotted path of the
    offending key (``wheels.torque_max_Nm``, ``requirements.keep_out[0].half_angle_deg``):
    unknown keys (with a "did you mean" suggestion), missing required keys,
    wrong types, units written where a number is expected, physically
    impossible values (an inertia that breaks the triangle inequality,
    negative limits, wheel axes that do not span 3-D space, a wheel set
    whose spin inertia exceeds the body's ...), unknown presets (listing the
    valid ones) and TOML syntax errors (with line and column). The objects
    are built once during validation, so a file that loads always builds.

The built-in default (``attitude/data/default_spacecraft.toml``, read with
:func:`default_config`; :func:`default_config_text` is the commented file
``attitude init`` writes) is a 12U CubeSat; its comments give the source of
every figure. :func:`config_to_toml` writes a resolved file (every default
filled in) that loads back to an equal configuration.
"""

from attitude.config.model import (
    PYRAMID_ELEVATION_DEG,
    WHEEL_LAYOUTS,
    CoarseSunSensorsConfig,
    ControlConfig,
    ControlFilterConfig,
    DetumbleConfig,
    Dispersion,
    EnvironmentConfig,
    FineSunSensorConfig,
    FlexibleModeConfig,
    GyroConfig,
    InertiaConfig,
    KeepOutConfig,
    LQRBounds,
    MagnetometerConfig,
    MagnetorquersConfig,
    MomentumConfig,
    MonteCarloConfig,
    OrbitConfig,
    PanelConfig,
    PlateConfig,
    RequirementsConfig,
    SlewRequirement,
    SpacecraftConfig,
    StarTrackerConfig,
    SurfaceConfig,
    UncertaintyConfig,
    WheelsConfig,
)
from attitude.config.reader import (
    DEFAULT_CONFIG_FILE,
    config_from_dict,
    default_config,
    default_config_text,
    load_config,
    parse_config,
)
from attitude.config.schema import CONFIG_KEYS, ConfigError
from attitude.config.writer import config_to_toml

__all__ = [
    "CONFIG_KEYS",
    "DEFAULT_CONFIG_FILE",
    "PYRAMID_ELEVATION_DEG",
    "WHEEL_LAYOUTS",
    "CoarseSunSensorsConfig",
    "ConfigError",
    "ControlConfig",
    "ControlFilterConfig",
    "DetumbleConfig",
    "Dispersion",
    "EnvironmentConfig",
    "FineSunSensorConfig",
    "FlexibleModeConfig",
    "GyroConfig",
    "InertiaConfig",
    "KeepOutConfig",
    "LQRBounds",
    "MagnetometerConfig",
    "MagnetorquersConfig",
    "MomentumConfig",
    "MonteCarloConfig",
    "OrbitConfig",
    "PanelConfig",
    "PlateConfig",
    "RequirementsConfig",
    "SlewRequirement",
    "SpacecraftConfig",
    "StarTrackerConfig",
    "SurfaceConfig",
    "UncertaintyConfig",
    "WheelsConfig",
    "config_from_dict",
    "config_to_toml",
    "default_config",
    "default_config_text",
    "load_config",
    "parse_config",
]
