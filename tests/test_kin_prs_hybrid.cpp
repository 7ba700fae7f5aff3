// placeholder: filled by the kinematics work of issue 4
