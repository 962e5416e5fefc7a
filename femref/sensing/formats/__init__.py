"""Record-file readers, one module per format, each with a ``Reader`` class (:class:`~femref.sensing.formats.base.RecordReader`):
:mod:`.delimited` (CSV/TSV), :mod:`.hdf5`, :mod:`.mdf4` (asammdf), :mod:`.tdms` (npTDMS), :mod:`.uff58` (pyuff); the last
three need the ``formats`` extra. Which reader opens a file is :mod:`femref.sensing.record_files`' registry
(:data:`~femref.sensing.record_files.FORMATS`, :func:`~femref.sensing.record_files.open_reader`).
"""
