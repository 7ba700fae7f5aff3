/G1 X1
/3 G0 Z5
(unterminated comment
X1.2.3 Y--4 G
#<unclosed = [1+
)(
;
%
N
