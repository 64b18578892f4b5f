"""Files in, files out: one file of any kind (:func:`~skelfilter.jobs.denoise_file.denoise_file`)
and many files on Dask (:func:`~skelfilter.jobs.batch.denoise_many`)."""
