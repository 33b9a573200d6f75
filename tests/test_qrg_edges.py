"""Card values at the edges of the ranges the MSC Nastran Quick Reference Guide gives their
fields (issue 40): the value on the edge is accepted (the model builds, and where cheap it
solves), the value just beyond it is refused, the error naming file:line, card, id and field
and what was expected. Where the Guide accepts a value femcal cannot solve (a negative
density, an incompressible solid, a CBUSH spring offset) the refusal says it is femcal's
limitation. A valid deck refused is as wrong as an invalid one solved."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from femcal.errors import DeckError, FemcalWarning, ModelError
from femcal.model.build import load_model
from femcal.solve.normal_modes import solve_normal_modes

HEAD = "SOL 103\nCEND\nMETHOD = 1\nSPC = 1\nBEGIN BULK\nEIGRL,1,,,4\n"
STEEL = "MAT1,1,2.1+5,,.3,7.85-9"
ALU = "MAT1,1,7.+4,,.33,2.7-9"


def bars(prop: str = "PBAR,1,1,100.,800.,1200.,1500.", mat: str = STEEL, card: str = "CBAR",
         orient: str = "0.,1.,0.", extra: str = "") -> str:  # fmt: skip
    """Two bars (or beams) along X from grid 1 (clamped) to grid 3; grid 9 off the axis."""
    grids = "\n".join(f"GRID,{i + 1},,{100.0 * i},0.,0." for i in range(3))
    elems = "\n".join(f"{card},{i + 1},1,{i + 1},{i + 2},{orient}" for i in range(2))
    return (f"{HEAD}{grids}\nGRID,9,,0.,100.,0.\n{elems}\n{prop}\n{mat}\nSPC1,1,123456,1,9\n"
            f"{extra}\nENDDATA\n")  # fmt: skip


def plate(prop: str = "PSHELL,1,1,2.,1,,1", mat: str = ALU, quad: str = "CQUAD4,1,1,1,2,3,4",
          extra: str = "") -> str:  # fmt: skip
    """One 100 x 100 shell (or shear panel) clamped along its edge 1-4."""
    grids = "GRID,1,,0.,0.,0.\nGRID,2,,100.,0.,0.\nGRID,3,,100.,100.,0.\nGRID,4,,0.,100.,0."
    return f"{HEAD}{grids}\n{quad}\n{prop}\n{mat}\nSPC1,1,123456,1,4\n{extra}\nENDDATA\n"


def rods(prop: str = "PROD,1,1,10.", card: str = "CROD,{e},1,{a},{b}") -> str:
    """Two rods 1-2 and 2-3 at a right angle, grids 1 and 3 clamped."""
    grids = "GRID,1,,0.,0.,0.\nGRID,2,,100.,0.,0.\nGRID,3,,100.,100.,0."
    elems = "\n".join(card.format(e=e, a=a, b=b) for e, a, b in ((1, 1, 2), (2, 2, 3)))
    return (f"{HEAD}{grids}\n{elems}\n{prop}\n{STEEL}\nSPC1,1,123456,1,3\nSPC1,1,456,2\n"
            "ENDDATA\n")  # fmt: skip


def bush(pbush: str = "PBUSH,1,K,100.,,,100.", cbush: str = "CBUSH,1,1,1,2") -> str:
    """A bush from grid 1 (clamped) to grid 2, which carries a unit mass and inertia."""
    return (f"{HEAD}GRID,1,,0.,0.,0.\nGRID,2,,10.,0.,0.\n{cbush}\n{pbush}\n"
            "CONM2,9,2,,1.\n,1.,,1.,,,1.\nSPC1,1,123456,1\nENDDATA\n")  # fmt: skip


def hexa(mat: str = STEEL) -> str:
    """One unit brick, its face z = 0 held in translation."""
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1),
               (0, 1, 1)]  # fmt: skip
    grids = "\n".join(f"GRID,{i + 1},,{x}.,{y}.,{z}." for i, (x, y, z) in enumerate(corners))
    return (f"{HEAD}{grids}\nCHEXA,1,1,1,2,3,4,5,6\n,7,8\nPSOLID,1,1\n{mat}\n"
            "SPC1,1,123,1,2,3,4\nENDDATA\n")  # fmt: skip


SCALAR = "SPOINT,7\nCELAS4,7,100.,7\nCMASS4,8,1.,7"


def _eigen(card: str) -> str:
    return bars().replace("EIGRL,1,,,4", card)


#: Decks with a value on the edge of its field's range: (text, whether to solve it).
ACCEPTED: list = []
#: Decks with a value just beyond it: (text, first line of the card at fault, what the error
#: says, the error's type).
REFUSED: list = []


def accept(name: str, text: str, solve: bool = True) -> None:
    ACCEPTED.append(pytest.param(text, solve, id=name))


def refuse(name: str, text: str, line: str, message: str, error: type = ModelError) -> None:
    REFUSED.append(pytest.param(text, line, message, error, id=name))


# GRID: 0 < ID < 100,000,000; CD >= -1 (-1: a fluid grid point, not modelled by femcal)
accept("GRID ID 99999999", bars(extra="GRID,99999999,,0.,0.,9."), solve=False)
refuse("GRID ID 100000000", bars(extra="GRID,100000000,,0.,0.,9."), "GRID,100000000,,0.,0.,9.",
       "GRID 100000000 field ID = 100000000: expected an id from 1 to 99999999")
refuse("GRID ID 0", bars(extra="GRID,0,,0.,0.,9."), "GRID,0,,0.,0.,9.",
       "GRID 0 field ID = 0: expected an id from 1 to 99999999")
accept("GRID CD 0", bars(extra="GRID,4,,0.,0.,9.,0"), solve=False)
refuse("GRID CD -1", bars(extra="GRID,4,,0.,0.,9.,-1"), "GRID,4,,0.,0.,9.,-1",
       "GRID CD -1 is not a defined coordinate system (CD -1, a fluid grid point, is not "
       "supported by femcal)")
# CORD2R: CID > 0; the three points not on one line
accept("CORD2R CID 1", bars(extra="CORD2R,1,,0.,0.,0.,0.,0.,1.\n,1.,0.,0."), solve=False)
refuse("CORD2R CID 0", bars(extra="CORD2R,0,,0.,0.,0.,0.,0.,1.\n,1.,0.,0."),
       "CORD2R,0,,0.,0.,0.,0.,0.,1.", "CORD2R 0 field CID = 0: expected an id from 1 to")
# MAT1: E, G >= 0.0 (not both blank); -1.0 < NU <= 0.5; RHO real (femcal: >= 0)
accept("MAT1 E 0", bars(mat="MAT1,1,0.,8.+4,,7.85-9"))
refuse("MAT1 E -1", bars(mat="MAT1,1,-1.,8.+4,,7.85-9"), "MAT1,1,-1.,8.+4,,7.85-9",
       "MAT1 1 field E = -1: expected a real >= 0")
accept("MAT1 G 0 (bars)", bars(mat="MAT1,1,2.1+5,0.,.3,7.85-9"))
refuse("MAT1 G -1", bars(mat="MAT1,1,2.1+5,-1.,.3,7.85-9"), "MAT1,1,2.1+5,-1.,.3,7.85-9",
       "MAT1 1 field G = -1: expected a real >= 0")
refuse("MAT1 E and G blank", plate(mat="MAT1,1,,,.33,2.7-9"), "MAT1,1,,,.33,2.7-9",
       "MAT1 1 has neither E nor G; expected at least one")
accept("MAT1 NU 0.5 (shell)", plate(mat="MAT1,1,7.+4,,.5,2.7-9"))
refuse("MAT1 NU 0.5000001", plate(mat="MAT1,1,7.+4,,.5000001,2.7-9"),
       "MAT1,1,7.+4,,.5000001,2.7-9",
       "MAT1 1 field NU = 0.5000001: expected a Poisson's ratio in (-1, 0.5]")
accept("MAT1 NU -0.999", plate(mat="MAT1,1,7.+4,,-.999,2.7-9"))
refuse("MAT1 NU -1", plate(mat="MAT1,1,7.+4,,-1.,2.7-9"), "MAT1,1,7.+4,,-1.,2.7-9",
       "MAT1 1 field NU = -1: expected a Poisson's ratio in (-1, 0.5]")
accept("MAT1 NU 0.49 (solid)", hexa("MAT1,1,2.1+5,,.49,7.85-9"))
refuse("MAT1 NU 0.5 (solid)", hexa("MAT1,1,2.1+5,,.5,7.85-9"), "MAT1,1,2.1+5,,.5,7.85-9",
       "MAT1 1 field NU = 0.5 (incompressible), used by solids (PSOLID): expected NU below "
       "0.5; femcal's solid elements cannot take an incompressible material")
accept("MAT1 RHO 0", bars(mat="MAT1,1,2.1+5,,.3,0."), solve=False)
refuse("MAT1 RHO -1e-9", bars(mat="MAT1,1,2.1+5,,.3,-1.-9"), "MAT1,1,2.1+5,,.3,-1.-9",
       "MAT1 1 field RHO = -1e-09: expected a real >= 0 (a mass density; the Guide allows any "
       "real, but femcal does not solve the negative mass of a negative one)")
# MAT8: E1, E2 other than 0.0; G1Z, G2Z >= 0.0 or blank (0 or blank: no shear flexibility)
_MAT8 = "PSHELL,1,8,2.,8,,8"
accept("MAT8 E1 1e-3", plate(_MAT8, mat=f"{ALU}\nMAT8,8,1.-3,1.+4,.3,5.+3,0.,0.,1.6-9"))
refuse("MAT8 E1 0", plate(_MAT8, mat=f"{ALU}\nMAT8,8,0.,1.+4,.3,5.+3,0.,0.,1.6-9"),
       "MAT8,8,0.,1.+4,.3,5.+3,0.,0.,1.6-9", "MAT8 8 field E1 = 0: expected a real other than 0")
# PSHELL: T real (femcal: >= 0); 12I/T**3 > 0.0, TS/T > 0.0 where MID2, MID3 use them
accept("PSHELL T 1e-3", plate("PSHELL,1,1,1.-3,1,,1"))
refuse("PSHELL T -2", plate("PSHELL,1,1,-2.,1,,1"), "PSHELL,1,1,-2.,1,,1",
       "PSHELL 1 field T = -2: expected a real >= 0 (a thickness; the Guide allows any real, "
       "but femcal does not solve")
accept("PSHELL 12I/T**3 1e-6", plate("PSHELL,1,1,2.,1,1.-6,1"))
refuse("PSHELL 12I/T**3 0", plate("PSHELL,1,1,2.,1,0.,1"), "PSHELL,1,1,2.,1,0.,1",
       "PSHELL 1 field 12I/T**3 = 0: expected a real > 0 (MID2 is given)")
accept("PSHELL 12I/T**3 0 without MID2", plate("PSHELL,1,1,2.,,0.,,0."), solve=False)
accept("PSHELL TS/T 1e-6", plate("PSHELL,1,1,2.,1,,1,1.-6"))
refuse("PSHELL TS/T 0", plate("PSHELL,1,1,2.,1,,1,0."), "PSHELL,1,1,2.,1,,1,0.",
       "PSHELL 1 field TS/T = 0: expected a real > 0 (MID3 is given)")
# CQUAD4: Ti >= 0.0 or blank, not all zero; TFLAG 0, 1 or blank; MCID >= 0
accept("CQUAD4 T1 0", plate(quad="CQUAD4,1,1,1,2,3,4\n,,,0.,2.,2.,2."))
refuse("CQUAD4 T1 -1", plate(quad="CQUAD4,1,1,1,2,3,4\n,,,-1.,2.,2.,2."), "CQUAD4,1,1,1,2,3,4",
       "CQUAD4 1 field T1 = -1: expected a real >= 0 (a thickness) or blank")
refuse("CQUAD4 Ti all 0", plate(quad="CQUAD4,1,1,1,2,3,4\n,,,0.,0.,0.,0."), "CQUAD4,1,1,1,2,3,4",
       "CQUAD4 1 field T1 = 0: expected T1 ... not all zero")
accept("CQUAD4 TFLAG 1", plate(quad="CQUAD4,1,1,1,2,3,4\n,,1,1.,1.,1.,1."))
refuse("CQUAD4 TFLAG 2", plate(quad="CQUAD4,1,1,1,2,3,4\n,,2,1.,1.,1.,1."), "CQUAD4,1,1,1,2,3,4",
       "CQUAD4 1 field TFLAG = 2: expected 0, 1 or blank")
accept("CQUAD4 MCID 0", plate(quad="CQUAD4,1,1,1,2,3,4,0"))
refuse("CQUAD4 MCID -1", plate(quad="CQUAD4,1,1,1,2,3,4,-1"), "CQUAD4,1,1,1,2,3,4,-1",
       "CQUAD4 1 field THETA/MCID = -1: expected a coordinate system id >= 0")
# PCOMP: Ti real (femcal: >= 0; 0 is a ply of no stiffness)
accept("PCOMP T 0", plate("PCOMP,1\n,1,2.,0.,YES,1,0.,45."))
refuse("PCOMP T -1", plate("PCOMP,1\n,1,2.,0.,YES,1,-1.,45."), ",1,2.,0.,YES,1,-1.,45.",
       "PCOMP field 7: found '-1.'; expected a ply thickness >= 0", DeckError)
# PSHEAR: T other than 0.0 (femcal: > 0); F1, F2 >= 0.0
accept("PSHEAR F1 0", plate("PSHEAR,1,1,2.,,0.", quad="CSHEAR,1,1,1,2,3,4"))
refuse("PSHEAR F1 -0.1", plate("PSHEAR,1,1,2.,,-.1", quad="CSHEAR,1,1,1,2,3,4"),
       "PSHEAR,1,1,2.,,-.1", "PSHEAR 1 field F1 = -0.1: expected a real >= 0")
refuse("PSHEAR T 0", plate("PSHEAR,1,1,0.", quad="CSHEAR,1,1,1,2,3,4"), "PSHEAR,1,1,0.",
       "PSHEAR 1 field T = 0: expected a real > 0 (a thickness; the Guide refuses 0")
# PROD, CONROD: A real (femcal: >= 0)
accept("PROD A 0", rods("PROD,1,1,0."), solve=False)
refuse("PROD A -1", rods("PROD,1,1,-1."), "PROD,1,1,-1.",
       "PROD 1 field A = -1: expected a real >= 0 (an area; the Guide allows any real")
accept("CONROD A 0", rods("", "CONROD,{e},{a},{b},1,0."), solve=False)
refuse("CONROD A -1", rods("", "CONROD,{e},{a},{b},1,-1."), "CONROD,1,1,2,1,-1.",
       "CONROD 1 field A = -1: expected a real >= 0 (an area")
# PTUBE: OD > 0.0; T <= OD/2 (0 or blank: a solid rod)
accept("PTUBE T OD/2", rods("PTUBE,1,1,2.,1.", "CTUBE,{e},1,{a},{b}"))
refuse("PTUBE T above OD/2", rods("PTUBE,1,1,2.,1.001", "CTUBE,{e},1,{a},{b}"),
       "PTUBE,1,1,2.,1.001", "PTUBE 1 field T = 1.001: expected a thickness from 0 to OD/2")
refuse("PTUBE OD 0", rods("PTUBE,1,1,0.", "CTUBE,{e},1,{a},{b}"), "PTUBE,1,1,0.",
       "PTUBE 1 field OD = 0: expected a real > 0 (a diameter)")
# PBAR: A, J real (femcal: >= 0); I1, I2 >= 0.0; I1*I2 > I12**2 where I12 is given; K1, K2
# blank where A is 0
_MASS = "CONM2,8,3,,1.-3"
accept("PBAR A 0", bars("PBAR,1,1,0.,800.,1200.,1500.", extra=_MASS))
refuse("PBAR A -1", bars("PBAR,1,1,-1.,800.,1200.,1500."), "PBAR,1,1,-1.,800.,1200.,1500.",
       "PBAR 1 field A = -1: expected a real >= 0 (an area; the Guide allows any real")
refuse("PBAR K1 with A 0", bars("PBAR,1,1,0.,800.,1200.,1500.\n,,,,,,,,\n,.8", extra=_MASS),
       "PBAR,1,1,0.,800.,1200.,1500.", "PBAR 1 field K1 = 0.8: expected blank where A is 0")
accept("PBAR I2 0", bars("PBAR,1,1,100.,800.,0.,1500."))
refuse("PBAR I2 -1", bars("PBAR,1,1,100.,800.,-1.,1500."), "PBAR,1,1,100.,800.,-1.,1500.",
       "PBAR 1 field I2 = -1: expected a real >= 0 (an area moment)")
accept("PBAR J 0", bars("PBAR,1,1,100.,800.,1200.,0."))
refuse("PBAR J -1", bars("PBAR,1,1,100.,800.,1200.,-1."), "PBAR,1,1,100.,800.,1200.,-1.",
       "PBAR 1 field J = -1: expected a real >= 0 (a torsion constant")
accept("PBAR I12 below", bars("PBAR,1,1,100.,800.,1200.,1500.\n,,,,,,,,\n,,,979."))
refuse("PBAR I12 at", bars("PBAR,1,1,100.,800.,1200.,1500.\n,,,,,,,,\n,,,979.8"),
       "PBAR,1,1,100.,800.,1200.,1500.", "PBAR 1 field I12 = 979.8: expected I1*I2 > I12^2")
# CBAR: G0 > 0, other than GA and GB
accept("CBAR G0 off the axis", bars(orient="9"))
refuse("CBAR G0 = GA", bars(orient="1"), "CBAR,1,1,1,2,1",
       "CBAR 1 field G0 = 1: expected a grid other than GA and GB")
# PBEAM: A(A) > 0.0; I1*I2 > I12**2 where I12 is given; 0.0 < X/XB <= 1.0
_BEAM = "PBEAM,1,1,100.,800.,1200.,,1500."
accept("PBEAM A(A) 1e-3", bars("PBEAM,1,1,1.-3,800.,1200.,,1500.", card="CBEAM"))
refuse("PBEAM A(A) 0", bars("PBEAM,1,1,0.,800.,1200.,,1500.", card="CBEAM"),
       "PBEAM,1,1,0.,800.,1200.,,1500.", "PBEAM 1 field A(A) = 0: expected a real > 0")
accept("PBEAM X/XB 1", bars(f"{_BEAM}\n,,,,,,,,\n,NO,1.,50.", card="CBEAM"))
refuse("PBEAM X/XB 1.5", bars(f"{_BEAM}\n,,,,,,,,\n,NO,1.5,50.", card="CBEAM"), _BEAM,
       "PBEAM 1 field X/XB = 1.5: expected a real in (0, 1]")
# PBARL, PBEAML: DIMi > 0.0; PBEAML 0.0 < X(j)/XB <= 1.0 (default 1.0)
accept("PBARL DIM1 1e-3", bars("PBARL,1,1,,ROD\n,1.-3"))
refuse("PBARL DIM1 0", bars("PBARL,1,1,,ROD\n,0."), "PBARL,1,1,,ROD",
       "PBARL 1 field DIM1 = 0: expected a real > 0 (a dimension of the ROD section)")
accept("PBEAML X(1)/XB blank", bars("PBEAML,1,1,,ROD\n,5.,,YES,,4.", card="CBEAM"))
refuse("PBEAML X(1)/XB 0", bars("PBEAML,1,1,,ROD\n,5.,,YES,0.,4.", card="CBEAM"),
       "PBEAML,1,1,,ROD", "PBEAML 1 field X(1)/XB = 0: expected a real in (0, 1]")
# CBUSH: without GO, X1-X3 and CID only K1, K4 (remark 5); OCID >= -1 (femcal: -1)
accept("CBUSH GA-GB axis with K1, K4", bush())
refuse("CBUSH GA-GB axis with K2", bush("PBUSH,1,K,100.,1."), "CBUSH,1,1,1,2",
       "CBUSH 1 has neither GO, X1-X3 nor CID, and its PBUSH 1 gives K2: expected an "
       "orientation (GO or X1-X3) or a CID")
accept("CBUSH OCID -1", bush(cbush="CBUSH,1,1,1,2,0.,1.,0.\n,,-1"))
refuse("CBUSH OCID 0", bush(cbush="CBUSH,1,1,1,2,0.,1.,0.\n,,0,1.,0.,0."), "CBUSH,1,1,1,2,0.,1.,0.",
       "CBUSH 1 field OCID = 0: expected -1 or blank (femcal does not model the spring offset")
# SPC1: C 1-6 at grids; 0, 1 or blank at scalar points. SPC: C 0 or 1 only at scalar points
accept("SPC1 C blank at an SPOINT", bars(extra=f"{SCALAR}\nSPC1,1,,7"))
refuse("SPC1 C blank at a GRID", bars(extra="SPC1,1,,3"), "SPC1,1,,3",
       "SPC1 set 1 field C = 0 (or blank) at GRID [3]: expected component numbers 1-6")
accept("SPC C 0 at an SPOINT", bars(extra=f"{SCALAR}\nSPC,1,7,0"))
refuse("SPC C 0 at a GRID", bars(extra="SPC,1,3,0"), "SPC,1,3,0",
       "SPC set 1 field C = 0 at GRID 3: expected component numbers 1-6")
# MPC: Aj real, default 0.0, except A1 nonzero; Cj 1-6 at grids, blank, 0 or 1 at scalar
# points
_MPC = "SPC = 1\nMPC = 1"
accept("MPC A2 blank", bars(extra="MPC,1,3,3,1.,2,3,").replace("SPC = 1", _MPC))
refuse("MPC A1 0", bars(extra="MPC,1,3,3,0.,2,3,1.").replace("SPC = 1", _MPC),
       "MPC,1,3,3,0.,2,3,1.", "MPC field 5: found '0.'; expected a coefficient A1 other than 0",
       DeckError)
accept("MPC C1 1 at an SPOINT",
       bars(extra=f"{SCALAR}\nMPC,1,7,1,1.,3,3,-1.").replace("SPC = 1", _MPC))
# RBE2: CM integers 1 through 6
accept("RBE2 CM 123456", bars(extra="GRID,4,,300.,0.,0.\nRBE2,5,3,123456,4"))
refuse("RBE2 CM 0", bars(extra="GRID,4,,300.,0.,0.\nRBE2,5,3,0,4"), "RBE2,5,3,0,4",
       "RBE2 field 4: found '0'; expected component numbers of digits 1-6", DeckError)
# CELAS1: C 1-6 at grids, 0 or blank at scalar points
accept("CELAS1 C1 6", bars(extra="PELAS,5,100.\nCELAS1,5,5,3,6"))
refuse("CELAS1 C1 7", bars(extra="PELAS,5,100.\nCELAS1,5,5,3,7"), "CELAS1,5,5,3,7",
       "CELAS1 field 5 (C1): found '7'; expected a component code of distinct digits 1-6",
       DeckError)
refuse("CELAS1 C1 0 at a GRID", bars(extra="PELAS,5,100.\nCELAS1,5,5,3,0"), "CELAS1,5,5,3,0",
       "CELAS1 5: component must be one digit 1-6 at a GRID and 0 or blank at a SPOINT")
# EIGRL: ND > 0 or blank; V1 < V2 (either may be negative). EIGR: ND >= 0 (0: the roots
# between F1 and F2); F1 < F2
accept("EIGRL ND 1", _eigen("EIGRL,1,,,1"))
refuse("EIGRL ND 0", _eigen("EIGRL,1,,,0"), "EIGRL,1,,,0",
       "EIGRL field 5: found '0'; expected an integer > 0 (the number of roots) or blank",
       DeckError)
accept("EIGRL V2 negative", _eigen("EIGRL,1,-10.,-1.,4"))
refuse("EIGRL V2 = V1", _eigen("EIGRL,1,10.,10.,4"), "EIGRL,1,10.,10.,4",
       "EIGRL field 4: found '10.'; expected a frequency above V1 = 10.", DeckError)
accept("EIGR ND 0", _eigen("EIGR,1,MGIV,0.,1.+4,,0"))
refuse("EIGR ND -1", _eigen("EIGR,1,MGIV,0.,1.+4,,-1"), "EIGR,1,MGIV,0.,1.+4,,-1",
       "EIGR 1 field ND = -1: expected an integer >= 0 or blank")
refuse("EIGR F2 = F1", _eigen("EIGR,1,MGIV,10.,10.,,0"), "EIGR,1,MGIV,10.,10.,,0",
       "EIGR 1 field F2 = 10: expected F2 above F1")


def _frequencies(path) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemcalWarning)
        return solve_normal_modes(load_model(path))[0].frequencies_hz


@pytest.mark.parametrize("text, solve", ACCEPTED)
def test_a_value_on_the_edge_of_the_guides_range_is_accepted(write, text, solve):
    path = write(text)
    if solve:
        assert np.isfinite(_frequencies(path)).all()
    else:
        load_model(path)


@pytest.mark.parametrize("text, line, message, error", REFUSED)
def test_a_value_beyond_the_guides_range_is_refused_naming_where_and_what(
    write, text, line, message, error
):
    path = write(text)
    with pytest.raises(error) as e:
        _frequencies(path)
    at = text.splitlines().index(line) + 1
    assert f"{path}:{at}: " in str(e.value)
    assert message in str(e.value)


def test_an_mpc_component_of_2_at_a_scalar_point_is_refused(write):
    """QRG MPC: a scalar point's component is blank, 0 or 1 (the constraint's error names
    the set and the point)."""
    text = bars(extra=f"{SCALAR}\nMPC,1,7,2,1.,3,3,-1.").replace("SPC = 1", _MPC)
    with pytest.raises(ModelError, match=r"MPC set 1: GRID/SPOINT \[7\] need a component 1-6 at "
                       r"a GRID, and 0, 1 or blank at an SPOINT"):  # fmt: skip
        _frequencies(write(text))


def test_zero_or_blank_means_what_nastran_makes_of_it(write):
    """A PTUBE T of 0 is a solid rod, as blank is (QRG PTUBE remark 1); MAT8 G1Z, G2Z of 0
    are no transverse shear flexibility, as blank and no MID3 are (QRG MAT8 remark 2); a
    CBUSH without orientation or CID is a spring along GA-GB (QRG CBUSH remark 5); a PBAR's
    K1, K2 are ignored where I12 is given (QRG PBAR remark 5); a MAT1 with G = 0 gives bars
    no torsional stiffness, as E alone does (QRG MAT1 remark 2)."""

    def hz(text: str) -> np.ndarray:
        return _frequencies(write(text, f"d{len(text)}.bdf"))

    tube = hz(rods("PTUBE,1,1,2.", "CTUBE,{e},1,{a},{b}"))
    assert hz(rods("PTUBE,1,1,2.,0.", "CTUBE,{e},1,{a},{b}")) == pytest.approx(tube)
    mat8 = f"{ALU}\nMAT8,8,1.5+5,1.+4,.3,5.+3,{{}},{{}},1.6-9"
    rigid = hz(plate(_MAT8, mat=mat8.format("", "")))
    assert hz(plate(_MAT8, mat=mat8.format("0.", "0."))) == pytest.approx(rigid)
    assert hz(plate("PSHELL,1,8,2.,8", mat=mat8.format("", ""))) == pytest.approx(rigid)
    # K1 = K4 = 100 on a unit mass and inertia: 10 rad/s along and about GA-GB
    assert hz(bush()) == pytest.approx([10 / (2 * np.pi)] * 2)
    # QRG PBAR remark 5: K1 and K2 are ignored where I12 is given
    skew = "PBAR,1,1,100.,800.,1200.,1500.\n,,,,,,,,\n,{},{},500."
    assert hz(bars(skew.format(".1", ".1"))) == pytest.approx(hz(bars(skew.format("", ""))))
    e_only = hz(bars(mat="MAT1,1,2.1+5,,,7.85-9"))
    assert hz(bars(mat="MAT1,1,2.1+5,0.,.3,7.85-9")) == pytest.approx(e_only)


def test_a_negative_v1_keeps_the_rigid_body_modes(write):
    """QRG EIGRL remark 5: a negative V1 searches the negative roots too, so the rigid-body
    modes (roots of about 0, either sign) are among those found, as with V1 blank."""
    free = plate().replace("SPC1,1,123456,1,4\n", "")
    blank = _frequencies(write(free.replace("EIGRL,1,,,4", "EIGRL,1,,,8"), "b.bdf"))
    negative = _frequencies(write(free.replace("EIGRL,1,,,4", "EIGRL,1,-1.,,8"), "n.bdf"))
    assert len(negative) == 8 and np.abs(negative[:6]).max() < 1e-2
    assert negative == pytest.approx(blank, abs=1e-3)
