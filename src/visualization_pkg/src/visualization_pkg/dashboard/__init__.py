"""The operator dashboard of the presentation layer (paper section 3.3, Figure 10).

Pure logic (no rospy, no Qt): smach_model, userdata, executive_state, mission_stats, log_buffer,
diagnostics_tree, node_health, image_convert, manual_ops, node_control, shell_session, operator_events.
Qt panels (python_qt_binding, rospy glue): *_panel.py (rviz_panel and shell_panel only when enabled);
rosnode/roslaunch glue of the node module: node_layer; the window: main_window, app;
rqt plugins (only where rqt_gui_py exists): rqt_plugins.
"""
