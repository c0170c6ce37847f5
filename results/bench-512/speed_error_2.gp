set terminal pngcairo noenhanced size 900,600
set output 'results/bench-512/speed_error_2.png'
set title 'speed against error: rotated.vdb (512x512)'
set xlabel 'RMSE against reference'
set ylabel 'frame ms (median over views)'
set logscale xy
set key outside
set grid
plot 'results/bench-512/speed_error_2.dat' index 0 using 1:2 with linespoints title 'naive', 'results/bench-512/speed_error_2.dat' index 1 using 1:2 with linespoints title 'bbox', 'results/bench-512/speed_error_2.dat' index 2 using 1:2 with linespoints title 'octree', 'results/bench-512/speed_error_2.dat' index 3 using 1:2 with linespoints title 'sparseleap'
set terminal svg noenhanced size 900,600
set output 'results/bench-512/speed_error_2.svg'
set title 'speed against error: rotated.vdb (512x512)'
set xlabel 'RMSE against reference'
set ylabel 'frame ms (median over views)'
set logscale xy
set key outside
set grid
plot 'results/bench-512/speed_error_2.dat' index 0 using 1:2 with linespoints title 'naive', 'results/bench-512/speed_error_2.dat' index 1 using 1:2 with linespoints title 'bbox', 'results/bench-512/speed_error_2.dat' index 2 using 1:2 with linespoints title 'octree', 'results/bench-512/speed_error_2.dat' index 3 using 1:2 with linespoints title 'sparseleap'
