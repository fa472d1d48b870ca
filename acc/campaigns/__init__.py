"""Campaigns: grids and Monte-Carlo samples over scenario keys, resumable sweeps on local
processes or Dask, reports and figures, and CI gates on campaign metrics."""
