"""Property and material cards -> the physical inputs of the element kernels: MAT1/MAT2/MAT8/
MAT9 moduli, shell section resultants (PSHELL, PCOMP), bar and beam sections (PBARL, PBEAML)."""
