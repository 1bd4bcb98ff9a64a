"""Reproduce the MTBench paper's tables from ``conf/paper/`` (see ``docs/paper.md``).

    python -m mtbench.paper list                                   # tables, rows, availability
    python -m mtbench.paper run mt10_rand --rows vanilla,pcgrad --seeds 3 --frames 2e7 [--dry-run]
    python -m mtbench.paper report mt10_rand                       # -> docs/results/paper/mt10_rand.md
"""

from .paper_results import APPENDIX_HPARAMS, PAPER_LABELS, PAPER_TABLES, PAPER_VALUES, PaperValue, paper_value
from .rows import CONF_DIR, Row, compose_row, load_table, row_names, table_names

__all__ = [
    "APPENDIX_HPARAMS",
    "CONF_DIR",
    "PAPER_LABELS",
    "PAPER_TABLES",
    "PAPER_VALUES",
    "PaperValue",
    "Row",
    "compose_row",
    "load_table",
    "paper_value",
    "row_names",
    "table_names",
]
