"""Monte Carlo campaigns: dispersed runs of a scenario on Dask, stored per batch (Parquet),
resumable, replayable run by run (docs/campaigns.md)."""
