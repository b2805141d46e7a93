"""Robot logs in: CSV/Parquet/DataFrame ingestion, body velocity from poses, column mappings."""

from ._logs import ColumnMapping, Log, body_velocity_from_poses, load_column_mapping, read_log

__all__ = ["ColumnMapping", "Log", "body_velocity_from_poses", "load_column_mapping", "read_log"]
