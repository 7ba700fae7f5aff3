%
O1000 (MAIN PROGRAM)
(HEADER ONLY LINE)
(T1 D10 FLAT (NESTED) END)
N0005 G21 G90 G17 (units, mode, plane)  
N0010 G0 X0 Y0 Z5 (approach)(second)
  (indented comment line)

N0020 G1 Z-1.	(plunge) F100
/N0030 G1 X10	(skippable)
N0040 G1 X20 Y0   
N0050 M30 (end)
%
