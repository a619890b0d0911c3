"""``reproduce_table``: the paper experiments' tables as rows (or a
pandas DataFrame)."""

from ._bayestrack import reproduce_rows


def reproduce_table(name, full=False, *, out=None, **options):
    """Runs the paper experiment ``name`` as ``cargo xtask reproduce-table
    NAME`` does and returns its table(s).

    Returns a ``pandas.DataFrame`` when pandas is installed, a list of
    dicts otherwise; one row per table row, the column ``table`` naming the
    table it comes from (an experiment may print more than one), then one
    column per header, numbers as int/float and other cells as printed
    text.

    ``full=False`` runs quick mode (CI's numbers, seconds), ``full=True``
    the paper-scale run. Keyword ``options`` are the experiment's ``--set
    key=value`` options; an unknown key or bad value raises ``ValueError``
    naming the valid keys. The CSV/SVG files go under ``out/<name>/`` when
    ``out`` is given, to a temporary folder removed afterwards otherwise.
    """
    rows = reproduce_rows(name, full, out=out, **options)
    try:
        import pandas
    except ImportError:
        return rows
    return pandas.DataFrame(rows)
