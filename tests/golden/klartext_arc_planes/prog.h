; CC with two axes sets the plane of the arcs about it: CC Y Z makes CP an arc in the Y/Z plane,
; CC X Z one in the Z/X plane, under TOOL CALL Z (TNC 640 User's Manual, "Circle centre CC").
0  BEGIN PGM ARCPLANES MM
1  TOOL CALL 4 Z S6000
2  L  X+10  Y-10 R0 FMAX
3  L  Z+5 R0 FMAX
4  L  Z-2 F200
5  CC  Y-11  Z-2
6  CP IPA-90 DR- F600
7  L  Y-12  Z-3
8  CC  X+20  Y-12
9  CP IPA+90 DR+
10 L  X+40  Y-13
11 CC  X+40  Z+5
12 CP IPA+90 DR+
13 CC  X+40  Z+5
14 CP IPA-180 DR-
15 L  Z+50 FMAX M30
16 END PGM ARCPLANES MM
