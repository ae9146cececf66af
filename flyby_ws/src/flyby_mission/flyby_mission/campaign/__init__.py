"""Monte Carlo campaigns: dispersions of scenario keys (``dispersions``), the runner on Dask (``runner``) and the
statistics and report of a campaign's rows (``report``)."""
