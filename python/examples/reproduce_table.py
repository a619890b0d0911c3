"""Reproduce a paper table from Python (quick mode unless --full), as
`cargo xtask reproduce-table NAME` does; prints it (a pandas DataFrame when
pandas is installed, rows otherwise).

    python reproduce_table.py hikpf
    python reproduce_table.py ball --full particles=70
"""

import sys

import bayestrack as bt


def main(argv):
    full = "--full" in argv
    args = [a for a in argv if a != "--full"]
    name = args[0] if args else "hikpf"
    options = dict(a.split("=", 1) for a in args[1:])
    print("experiments:", ", ".join(bt.experiment_names()))
    table = bt.reproduce_table(name, full=full, **options)
    if isinstance(table, list):
        for row in table:
            print(row)
    else:
        print(table.to_string())


if __name__ == "__main__":
    main(sys.argv[1:])
