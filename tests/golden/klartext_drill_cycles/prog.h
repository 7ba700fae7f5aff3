; Drilling cycles that stay on the hole axis are one drill motion per call (TNC 640 User's Manual,
; "Cycles: drilling"): set-up clearance Q200 above the surface Q203, depth Q201, end at the 2nd
; set-up clearance Q204. Parameters in '~' continuation lines, in unnumbered lines (older
; controls) and as formulas; cycle 208 (bore milling, a helix) is refused at its call.
0  BEGIN PGM DRILLS MM
1  TOOL CALL 8 Z S2911
2  L  X+420  Y-87.5 R0 FMAX
3  L  Z+15 R0 FMAX
4  Q5 = -30 - 3
5  CYCL DEF 207 RIGID TAPPING ~
    Q200=+5    ;SET-UP CLEARANCE ~
    Q201=+Q5   ;DEPTH OF THREAD ~
    Q239=+1.27 ;THREAD PITCH ~
    Q203=+0    ;SURFACE COORDINATE ~
    Q204=+5    ;2ND SET-UP CLEARANCE
6  L FMAX M99
7  L  Y-12.5 FMAX M99
8  CYCL DEF 200 DRILLING
   Q200=2 ;SET-UP CLEARANCE
   Q201=-20 ;DEPTH
   Q206=150 ;FEED RATE FOR PLUNGING
   Q202=5 ;PLUNGING DEPTH
   Q210=0 ;DWELL TIME AT TOP
   Q203=-1 ;SURFACE COORDINATE
   Q204=50 ;2ND SET-UP CLEARANCE
   Q211=0 ;DWELL TIME AT DEPTH
9  L  X+20 FMAX
10 CYCL CALL
11 CYCL DEF 208 BORE MILLING ~
    Q200=+2 ;SET-UP CLEARANCE ~
    Q201=-10 ;DEPTH ~
    Q203=+0 ;SURFACE COORDINATE ~
    Q204=+50 ;2ND SET-UP CLEARANCE
12 L  X+50 FMAX M99
13 L  Z+100 FMAX M30
14 END PGM DRILLS MM
