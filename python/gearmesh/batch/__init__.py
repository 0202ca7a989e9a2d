"""Batches and studies (`gearmesh batch`, `gearmesh study`, docs/batch.md): the cases and one
case's run (cases), the run on a Dask cluster (run, with tasks and cluster), sampled studies (study,
study_report). Needs the batch extra (dask, distributed)."""
