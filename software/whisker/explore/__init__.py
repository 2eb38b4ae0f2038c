"""The design explorer (``whisker explore``): a grid of designs, the tasks each worker computes, the
study that runs them (joblib or Dask), and its tables and Pareto plots."""
