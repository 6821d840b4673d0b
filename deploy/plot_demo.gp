# Plot of a demo run, all on the slave's clock: the master position as the slave received it, the slave position and
# its fixture surface; then the operator force the master measured, the slave's command and its fixture force.
# gnuplot -e "slave='s.csv'; png='out.png'; wall=0.01; link='udp'" deploy/plot_demo.gp
set datafile separator ","
set terminal pngcairo size 1200,900 noenhanced font ",10"
set output png
if (!exists("link")) link = "UDP"
set multiplot layout 2,1 title sprintf("teleop demo: master and slave on the loopback plant (%s, 1 kHz)", link)
set grid
set key top left
set ylabel "position (mm)"
set xlabel "slave time (s)"
plot slave using (column("time_s")):(1e3*column("peer_position_m_0")) with lines lw 2 title "master x_m (received)", \
     slave using (column("time_s")):(1e3*column("position_m_0")) with lines lw 2 title "slave x_s", \
     1e3*wall with lines dt 2 lw 2 lc rgb "red" title "slave fixture surface"
set ylabel "force (N)"
plot slave using (column("time_s")):(column("peer_force_N_0")) with lines lw 2 title "operator force on master F_h", \
     slave using (column("time_s")):(column("command_N_0")) with lines title "slave actuator command F_as", \
     slave using (column("time_s")):(-column("fixture_force_N_0")) with lines lw 2 title "slave fixture force F_sVF"
unset multiplot
