##########
THIS POSTPROCESSOR IS A SAMPLE FOR MACHINE SIMULATION USAGE, IT DOES NOT OUTPUT ANY NC PROGRAM.

For more information on how to update your post processor with machine simulation support please visit:
https://knowledge.autodesk.com/community/article/356406
##########
