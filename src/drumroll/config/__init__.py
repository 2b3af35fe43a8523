"""The TOML config shared by every command: reading, validation and unit conversion."""

from drumroll.config.loader import Config, StickSpec, load_config, parse_config

__all__ = ["Config", "StickSpec", "load_config", "parse_config"]
