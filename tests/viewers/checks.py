"""What the ParaView checks share: a check's line, the datasets of a reader's output, their
arrays."""

import sys


def check(ok, what):
    """Print `ok   what` or `FAIL what`; exit 1 on a failure."""
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        sys.exit(1)


def leaves(data):
    """The datasets of a (possibly composite) output."""
    if data.IsA("vtkMultiBlockDataSet"):
        return [x for i in range(data.GetNumberOfBlocks()) for x in leaves(data.GetBlock(i))]
    if data.IsA("vtkMultiPieceDataSet"):
        return [x for i in range(data.GetNumberOfPieces()) for x in leaves(data.GetPiece(i))]
    return [data] if data is not None else []


def arrays(d):
    """The point and cell arrays' names of a dataset, sorted."""
    pd, cd = d.GetPointData(), d.GetCellData()
    return sorted(
        [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
        + [cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())]
    )
