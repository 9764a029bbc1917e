"""agvcal-fleet: agvcal solve and diagnose over a fleet's recordings, on Dask distributed,
results in a database, trends and alarms as an HTML report (docs/fleet.md)."""
